#include "storage/g2o_3d_reader.h"

#include <Eigen/Cholesky>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "storage/internal/g2o_graph.h"
#include "storage/internal/text_reader.h"
#include "storage/internal/upper_triangle.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
using VertexKind = internal::G2oVertexKind;

using Graph = internal::G2oGraph<internal::G2o3d>;
using internal::G2oEdgeKind;

constexpr const char* kKnownTags =
    "VERTEX_SE3:QUAT, VERTEX_TRACKXYZ, EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ, EDGE_SE3_XYZPRIOR, "
    "PARAMS_SE3OFFSET or FIX";

// x y z qx qy qz qw at fields [first, first + 7).
StatusOr<core::Pose3> ReadPose(const LineReader& reader, size_t first, std::string_view what) {
  double v[7];
  GS_RETURN_IF_ERROR(reader.Doubles(first, 7, what, v));
  core::Pose3 pose;
  pose.t = Eigen::Vector3d(v[0], v[1], v[2]);
  pose.q = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);
  const double norm = pose.q.norm();
  if (!(norm >= 0.9 && norm <= 1.1)) {
    return reader.Error(std::string(what) + " quaternion has norm " +
                        internal::FormatDouble(norm) + "; expected a unit quaternion (qx qy qz qw)");
  }
  pose.q.normalize();
  return pose;
}

class G2o3dParser {
 public:
  explicit G2o3dParser(core::InformationRepairs* repairs) : repairs_(repairs) {}

  StatusOr<core::Problem3d> Parse(const std::string& path) {
    return graph_.Read(path, [this](const LineReader& reader) { return ParseLine(reader); });
  }

 private:
  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "VERTEX_SE3:QUAT") return ParsePoseVertex(reader);
    if (tag == "VERTEX_TRACKXYZ") return ParsePointVertex(reader);
    if (tag == "EDGE_SE3:QUAT") return ParseRelativePose(reader);
    if (tag == "EDGE_SE3_TRACKXYZ") return ParsePointEdge(reader, G2oEdgeKind::kPointObservation);
    if (tag == "EDGE_SE3_XYZPRIOR") return ParsePointEdge(reader, G2oEdgeKind::kPositionPrior);
    if (tag == "PARAMS_SE3OFFSET") return ParseOffset(reader);
    if (tag == "FIX") return graph_.AddFix(reader);
    return reader.Unsupported("unknown tag '" + std::string(tag) + "' in a 3-D graph; expected " +
                              kKnownTags);
  }

  Status AddVertex(const LineReader& reader, int64_t id, VertexKind kind, int32_t index) {
    graph_.vertices().Define(id, kind, index, reader.line_number());
    return Status::Ok();
  }

  Status ParsePoseVertex(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(9));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
    GS_ASSIGN_OR_RETURN(const core::Pose3 pose, ReadPose(reader, 2, "estimate"));
    GS_RETURN_IF_ERROR(graph_.vertices().CheckUnique(reader, id, VertexKind::kPose));
    const int32_t index = graph_.problem().AddPose(id, pose, /*initialized=*/true, reader.line_number());
    return AddVertex(reader, id, VertexKind::kPose, index);
  }

  Status ParsePointVertex(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(5));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
    double v[3];
    GS_RETURN_IF_ERROR(reader.Doubles(2, 3, "estimate", v));
    GS_RETURN_IF_ERROR(graph_.vertices().CheckUnique(reader, id, VertexKind::kFeature));
    const int32_t index =
        graph_.problem().AddFeature(id, core::Point3(v[0], v[1], v[2]), /*initialized=*/true);
    return AddVertex(reader, id, VertexKind::kFeature, index);
  }

  Status ParseRelativePose(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(31));
    Graph::Pending item;
    item.kind = G2oEdgeKind::kRelativePose;
    item.line = reader.line_number();
    GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "from id"));
    GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "to id"));
    GS_ASSIGN_OR_RETURN(item.pose, ReadPose(reader, 3, "measurement"));
    double upper[21];
    GS_RETURN_IF_ERROR(reader.Doubles(10, 21, "information", upper, internal::Magnitude::kInformation));
    item.pose_information = internal::SymmetricFromUpper<6>(upper);
    if (!internal::IsPositiveDefiniteMatrix(item.pose_information) &&
        !core::RepairAndCount(repairs_, item.line, &item.pose_information))
      return reader.Error(
          "EDGE_SE3:QUAT information " + internal::UpperTriangleString(upper, 21) +
          " is not positive definite; expected a symmetric positive definite 6x6 matrix");
    if (item.ids[0] == item.ids[1])
      return reader.Error("EDGE_SE3:QUAT connects vertex " + std::to_string(item.ids[0]) +
                          " to itself; expected two distinct vertices");
    graph_.Add(item);
    return Status::Ok();
  }

  Status ParsePointEdge(const LineReader& reader, G2oEdgeKind kind) {
    const bool observation = kind == G2oEdgeKind::kPointObservation;
    const size_t first = observation ? 4 : 2;  // first measurement field
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(first + 3 + 6));
    Graph::Pending item;
    item.kind = kind;
    item.line = reader.line_number();
    GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "pose id"));
    if (observation) {
      GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "point id"));
      GS_ASSIGN_OR_RETURN(const int64_t param, reader.Id(3, "offset parameter id"));
      if (const auto it = offsets_.find(param); it != offsets_.end() && !it->second) {
        return reader.Unsupported("EDGE_SE3_TRACKXYZ uses PARAMS_SE3OFFSET " +
                                  std::to_string(param) +
                                  ", which is not the identity; expected an identity offset");
      }
    }
    double z[3], upper[6];
    GS_RETURN_IF_ERROR(reader.Doubles(first, 3, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(first + 3, 6, "information", upper,
                                       internal::Magnitude::kInformation));
    item.point = Eigen::Vector3d(z[0], z[1], z[2]);
    item.point_information = internal::SymmetricFromUpper<3>(upper);
    if (!internal::IsPositiveDefiniteMatrix(item.point_information) &&
        !core::RepairAndCount(repairs_, item.line, &item.point_information))
      return reader.Error(std::string(Graph::Tag(kind)) + " information " +
                          internal::UpperTriangleString(upper, 6) +
                          " is not positive definite; expected a symmetric positive definite "
                          "3x3 matrix");
    graph_.Add(item);
    return Status::Ok();
  }

  Status ParseOffset(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(9));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "parameter id"));
    GS_ASSIGN_OR_RETURN(const core::Pose3 offset, ReadPose(reader, 2, "offset"));
    const bool identity = offset.t.norm() <= 1e-12 && std::abs(std::abs(offset.q.w()) - 1.0) <= 1e-12;
    offsets_[id] = identity;
    return Status::Ok();
  }

  Graph graph_;
  std::unordered_map<int64_t, bool> offsets_;  // id -> is identity
  core::InformationRepairs* const repairs_;     // null: reject non-PD information
};

}  // namespace

StatusOr<core::Problem3d> ReadG2o3d(const std::string& path, core::InformationRepairs* repairs) {
  return G2o3dParser(repairs).Parse(path);
}

}  // namespace graphslam::storage
