#include "storage/g2o_3d_reader.h"

#include <cmath>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "storage/internal/g2o_graph.h"
#include "storage/internal/g2o_records.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
using Graph = internal::G2oGraph<internal::G2o3d>;
using internal::G2oEdgeKind;

constexpr const char* kKnownTags =
    "VERTEX_SE3:QUAT, VERTEX_TRACKXYZ, EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ, EDGE_SE3_XYZPRIOR, "
    "PARAMS_SE3OFFSET or FIX";

class G2o3dParser {
 public:
  explicit G2o3dParser(core::InformationRepairs* repairs) : graph_(repairs) {}

  StatusOr<core::Problem3d> Parse(const std::string& path) {
    return graph_.Read(path, [this](const LineReader& reader) { return ParseLine(reader); });
  }

 private:
  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "VERTEX_SE3:QUAT") return internal::ParseG2oPoseVertex(reader, &graph_).status();
    if (tag == "VERTEX_TRACKXYZ") return internal::ParseG2oPointVertex(reader, &graph_);
    if (tag == "EDGE_SE3:QUAT") return internal::ParseG2oRelativePose(reader, &graph_);
    if (tag == "EDGE_SE3_TRACKXYZ") return ParsePointEdge(reader, G2oEdgeKind::kPointObservation);
    if (tag == "EDGE_SE3_XYZPRIOR") return ParsePointEdge(reader, G2oEdgeKind::kPositionPrior);
    if (tag == "PARAMS_SE3OFFSET") return ParseOffset(reader);
    if (tag == "FIX") return graph_.AddFix(reader);
    return reader.Unsupported("unknown tag '" + std::string(tag) + "' in a 3-D graph; expected " +
                              kKnownTags);
  }

  // EDGE_SE3_TRACKXYZ pose point param x y z Omega(6), EDGE_SE3_XYZPRIOR pose
  // x y z Omega(6); param must name an identity PARAMS_SE3OFFSET (or none).
  Status ParsePointEdge(const LineReader& reader, G2oEdgeKind kind) {
    return internal::ParseG2oPointEdge(
        reader, kind, /*extra_fields=*/1, &graph_, [this](const LineReader& line) -> Status {
          GS_ASSIGN_OR_RETURN(const int64_t param, line.Id(3, "offset parameter id"));
          if (const auto it = offsets_.find(param); it != offsets_.end() && !it->second) {
            return line.Unsupported("EDGE_SE3_TRACKXYZ uses PARAMS_SE3OFFSET " +
                                    std::to_string(param) +
                                    ", which is not the identity; expected an identity offset");
          }
          return Status::Ok();
        });
  }

  Status ParseOffset(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(9));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "parameter id"));
    GS_ASSIGN_OR_RETURN(const core::Pose3 offset, internal::G2o3d::ReadPose(reader, 2, "offset"));
    const bool identity = offset.t.norm() <= 1e-12 && std::abs(std::abs(offset.q.w()) - 1.0) <= 1e-12;
    offsets_[id] = identity;
    return Status::Ok();
  }

  Graph graph_;
  std::unordered_map<int64_t, bool> offsets_;  // id -> is identity
};

}  // namespace

StatusOr<core::Problem3d> ReadG2o3d(const std::string& path,
                                    core::InformationRepairs* repairs) {
  return G2o3dParser(repairs).Parse(path);
}

}  // namespace graphslam::storage
