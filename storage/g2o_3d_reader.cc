#include "storage/g2o_3d_reader.h"

#include <cmath>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "storage/internal/g2o_graph.h"
#include "storage/internal/g2o_parser.h"
#include "storage/internal/g2o_records.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
using Graph3d = internal::G2oGraph<internal::G2o3d>;

constexpr const char* kKnownTags =
    "VERTEX_SE3:QUAT, VERTEX_TRACKXYZ, EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ, EDGE_SE3_XYZPRIOR, "
    "PARAMS_SE3OFFSET or FIX";

// What only the 3-D reader has (internal/g2o_parser.h: the Dialect): the
// sensor offsets (PARAMS_SE3OFFSET) that EDGE_SE3_TRACKXYZ names.
class G2o3dDialect {
 public:
  using Graph = internal::G2o3d;

  void OnPoseVertex(int32_t) {}

  // EDGE_SE3_TRACKXYZ pose point param x y z Omega(6): param must name an
  // identity PARAMS_SE3OFFSET (or none).
  Status CheckPointEdgeExtra(const LineReader& line) const {
    GS_ASSIGN_OR_RETURN(const int64_t param, line.Id(3, "offset parameter id"));
    if (const auto it = offsets_.find(param); it != offsets_.end() && !it->second) {
      return line.Unsupported("EDGE_SE3_TRACKXYZ uses PARAMS_SE3OFFSET " + std::to_string(param) +
                              ", which is not the identity; expected an identity offset");
    }
    return Status::Ok();
  }

  Status ParseOther(const LineReader& reader, std::string_view tag, Graph3d*) {
    if (tag == "PARAMS_SE3OFFSET") return ParseOffset(reader);
    return reader.Unsupported("unknown tag '" + std::string(tag) + "' in a 3-D graph; expected " +
                              kKnownTags);
  }

 private:
  Status ParseOffset(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(9));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "parameter id"));
    GS_ASSIGN_OR_RETURN(const core::Pose3 offset, internal::G2o3d::ReadPose(reader, 2, "offset"));
    const bool identity = offset.t.norm() <= 1e-12 && std::abs(std::abs(offset.q.w()) - 1.0) <= 1e-12;
    offsets_[id] = identity;
    return Status::Ok();
  }

  std::unordered_map<int64_t, bool> offsets_;  // id -> is identity
};

}  // namespace

StatusOr<core::Problem3d> ReadG2o3d(const std::string& path,
                                    core::InformationRepairs* repairs) {
  return internal::G2oParser<G2o3dDialect>(repairs).Parse(path);
}

}  // namespace graphslam::storage
