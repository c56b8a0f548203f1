#include "storage/dimension_detection.h"

#include <string_view>

#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

bool StartsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

// 1: 3-D, 0: 2-D, -1: undecided.
int Classify(std::string_view tag, InputFormat format) {
  if (format == InputFormat::kIsam) {
    if (tag == "EDGE3" || tag == "POINT3") return 1;
    if (tag == "EDGE2" || tag == "ODOMETRY" || tag == "LANDMARK") return 0;
    return -1;
  }
  if (format == InputFormat::kToro) {
    if (tag == "VERTEX3" || tag == "EDGE3") return 1;
    if (tag == "VERTEX2" || tag == "EDGE2" || tag == "BR" || tag == "EQUIV") return 0;
    return -1;
  }
  if (StartsWith(tag, "VERTEX_SE3") || tag == "VERTEX_TRACKXYZ" || StartsWith(tag, "EDGE_SE3") ||
      tag == "PARAMS_SE3OFFSET")
    return 1;
  if (StartsWith(tag, "VERTEX_SE2") || tag == "VERTEX_XY" || StartsWith(tag, "EDGE_SE2") ||
      StartsWith(tag, "EDGE_PRIOR_SE2") || StartsWith(tag, "DATA_"))
    return 0;
  return -1;
}

}  // namespace

StatusOr<bool> IsThreeDimensional(const std::string& path, InputFormat format) {
  if (format != InputFormat::kG2o && format != InputFormat::kIsam && format != InputFormat::kToro)
    return false;
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  while (reader->Next()) {
    const int kind = Classify(reader->fields()[0], format);
    if (kind >= 0) return kind == 1;
  }
  GS_RETURN_IF_ERROR(reader->status());
  return false;
}

}  // namespace graphslam::storage
