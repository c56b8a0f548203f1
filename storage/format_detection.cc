#include "storage/format_detection.h"

#include <filesystem>

#include "storage/g2o_3d_reader.h"
#include "storage/g2o_reader.h"
#include "storage/internal/text_reader.h"
#include "storage/isam_3d_reader.h"
#include "storage/isam_reader.h"
#include "storage/native_log_reader.h"
#include "storage/toro_reader.h"

namespace graphslam::storage {
namespace {

bool StartsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

// True if `folder` holds some RobotN_Odometry.dat.
bool IsMrclamFolder(const std::string& folder) {
  std::error_code error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, error)) {
    const std::string name = entry.path().filename().string();
    if (StartsWith(name, "Robot") && name.size() > 18 &&
        name.substr(name.size() - 13) == "_Odometry.dat") {
      const std::string number = name.substr(5, name.size() - 18);
      if (!number.empty() &&
          number.find_first_not_of("0123456789") == std::string::npos) {
        return true;
      }
    }
  }
  return false;
}

}  // namespace

StatusOr<InputFormat> DetectInputFormat(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) {
    return Status::NotFound(path + ": no such file or directory; expected an input");
  }
  if (std::filesystem::is_directory(path, error)) {
    if (IsMrclamFolder(path)) return InputFormat::kMrclam;
    return Status::NotSupported(path +
                                ": is a directory without RobotN_Odometry.dat; expected an MRCLAM "
                                "dataset folder or a file");
  }
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  if (!reader->Next()) {
    GS_RETURN_IF_ERROR(reader->status());
    return Status::Corruption(path + ": has no records; expected a g2o, iSAM or native log file");
  }
  const std::string_view token = reader->fields()[0];
  if (token == kNativeLogMagic) return InputFormat::kNative;
  // A 3-D graph with points, as `solve -o` writes it, opens with PARAMS_SE3OFFSET.
  if (StartsWith(token, "VERTEX_") || StartsWith(token, "EDGE_") || token == "FIX" ||
      StartsWith(token, "DATA_") || StartsWith(token, "PARAMS_")) {
    return InputFormat::kG2o;
  }
  if (token == "ODOMETRY" || token == "EDGE2" || token == "EDGE3" || token == "LANDMARK" ||
      token == "POINT3") {
    return InputFormat::kIsam;
  }
  if (token == "VERTEX2" || token == "VERTEX3" || token == "BR" || token == "EQUIV")
    return InputFormat::kToro;
  return Status::NotSupported(
      reader->name() + ":" + std::to_string(reader->line_number()) + ": first record '" +
      std::string(token) +
      "' matches no known format; expected VERTEX_*/EDGE_*/PARAMS_*/FIX (g2o), ODOMETRY/EDGE2/LANDMARK "
      "(iSAM), VERTEX2/VERTEX3 (TORO .graph) or " + kNativeLogMagic + " (native log)");
}

StatusOr<InputFormat> ParseInputFormat(std::string_view name) {
  if (name == "g2o") return InputFormat::kG2o;
  if (name == "isam") return InputFormat::kIsam;
  if (name == "mrclam") return InputFormat::kMrclam;
  if (name == "native") return InputFormat::kNative;
  if (name == "toro") return InputFormat::kToro;
  return Status::InvalidArgument("input format '" + std::string(name) +
                                 "'; expected auto, g2o, isam, mrclam, native or toro");
}

const char* InputFormatName(InputFormat format) {
  switch (format) {
    case InputFormat::kG2o: return "g2o";
    case InputFormat::kIsam: return "isam";
    case InputFormat::kMrclam: return "mrclam";
    case InputFormat::kNative: return "native";
    case InputFormat::kToro: return "toro";
  }
  return "unknown";
}

StatusOr<core::Problem2d> ReadProblem(const std::string& path, InputFormat format,
                                      const MrclamOptions& mrclam,
                                      MrclamReadStats* mrclam_stats,
                                      core::InformationRepairs* repairs) {
  switch (format) {
    case InputFormat::kG2o: return ReadG2o(path, repairs);
    case InputFormat::kIsam: return ReadIsam(path, repairs);
    case InputFormat::kMrclam: return ReadMrclam(path, mrclam, mrclam_stats);
    case InputFormat::kNative: return ReadNativeLog(path, repairs);
    case InputFormat::kToro: return ReadToro(path, repairs);
  }
  return Status::InvalidArgument(
      "unknown InputFormat value; expected g2o, isam, mrclam, native or toro");
}

StatusOr<core::Problem3d> ReadProblem3d(const std::string& path, InputFormat format,
                                        core::InformationRepairs* repairs) {
  switch (format) {
    case InputFormat::kG2o: return ReadG2o3d(path, repairs);
    case InputFormat::kIsam: return ReadIsam3d(path, repairs);
    case InputFormat::kToro: return ReadToro3d(path, repairs);
    default: break;
  }
  return Status::NotSupported(path + ": format " + InputFormatName(format) +
                              " has no 3-D reader; expected g2o, isam or toro");
}

}  // namespace graphslam::storage
