#include "storage/g2o_3d_reader.h"

#include <Eigen/Cholesky>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "storage/internal/g2o_vertices.h"
#include "storage/internal/text_reader.h"
#include "storage/internal/upper_triangle.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
using VertexKind = internal::G2oVertexKind;

enum class PendingKind { kRelativePose, kPointObservation, kGps, kFix };

struct Pending {
  PendingKind kind;
  int64_t ids[2] = {0, 0};
  int64_t param = -1;
  int32_t line = 0;
  core::Pose3 pose;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  core::Matrix6d information6 = core::Matrix6d::Identity();
  Eigen::Matrix3d information3 = Eigen::Matrix3d::Identity();
};

const char* PendingTag(PendingKind kind) {
  switch (kind) {
    case PendingKind::kRelativePose: return "EDGE_SE3:QUAT";
    case PendingKind::kPointObservation: return "EDGE_SE3_TRACKXYZ";
    case PendingKind::kGps: return "EDGE_SE3_XYZPRIOR";
    case PendingKind::kFix: return "FIX";
  }
  return "?";
}

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
  explicit G2o3dParser(const std::string& path) : path_(path) {}

  StatusOr<core::Problem3d> Parse() {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(path_));
    name_ = reader->name();
    problem_.source = path_;
    while (reader->Next()) GS_RETURN_IF_ERROR(ParseLine(*reader));
    GS_RETURN_IF_ERROR(reader->status());
    if (vertices_.empty() && pending_.empty())
      return Status::Corruption(name_ + ": has no vertices or edges; expected a 3-D g2o graph");
    vertices_.Seal();
    for (const Pending& item : pending_) GS_RETURN_IF_ERROR(Resolve(item));
    return std::move(problem_);
  }

 private:
  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "VERTEX_SE3:QUAT") return ParsePoseVertex(reader);
    if (tag == "VERTEX_TRACKXYZ") return ParsePointVertex(reader);
    if (tag == "EDGE_SE3:QUAT") return ParseRelativePose(reader);
    if (tag == "EDGE_SE3_TRACKXYZ") return ParsePointEdge(reader, PendingKind::kPointObservation);
    if (tag == "EDGE_SE3_XYZPRIOR") return ParsePointEdge(reader, PendingKind::kGps);
    if (tag == "PARAMS_SE3OFFSET") return ParseOffset(reader);
    if (tag == "FIX") return ParseFix(reader);
    return reader.Unsupported("unknown tag '" + std::string(tag) + "' in a 3-D graph; expected " +
                              kKnownTags);
  }

  Status AddVertex(const LineReader& reader, int64_t id, VertexKind kind, int32_t index) {
    vertices_.Define(id, kind, index, reader.line_number());
    return Status::Ok();
  }

  Status ParsePoseVertex(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(9));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
    GS_ASSIGN_OR_RETURN(const core::Pose3 pose, ReadPose(reader, 2, "estimate"));
    GS_RETURN_IF_ERROR(vertices_.CheckUnique(reader, id, VertexKind::kPose));
    const int32_t index = problem_.AddPose(id, pose, /*initialized=*/true, reader.line_number());
    return AddVertex(reader, id, VertexKind::kPose, index);
  }

  Status ParsePointVertex(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(5));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
    double v[3];
    GS_RETURN_IF_ERROR(reader.Doubles(2, 3, "estimate", v));
    GS_RETURN_IF_ERROR(vertices_.CheckUnique(reader, id, VertexKind::kFeature));
    const int32_t index =
        problem_.AddFeature(id, core::Point3(v[0], v[1], v[2]), /*initialized=*/true);
    return AddVertex(reader, id, VertexKind::kFeature, index);
  }

  Status ParseRelativePose(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(31));
    Pending item;
    item.kind = PendingKind::kRelativePose;
    item.line = reader.line_number();
    GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "from id"));
    GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "to id"));
    GS_ASSIGN_OR_RETURN(item.pose, ReadPose(reader, 3, "measurement"));
    double upper[21];
    GS_RETURN_IF_ERROR(reader.Doubles(10, 21, "information", upper, internal::Magnitude::kInformation));
    item.information6 = internal::SymmetricFromUpper<6>(upper);
    if (!internal::IsPositiveDefiniteMatrix(item.information6))
      return reader.Error(
          "EDGE_SE3:QUAT information " + internal::UpperTriangleString(upper, 21) +
          " is not positive definite; expected a symmetric positive definite 6x6 matrix");
    if (item.ids[0] == item.ids[1])
      return reader.Error("EDGE_SE3:QUAT connects vertex " + std::to_string(item.ids[0]) +
                          " to itself; expected two distinct vertices");
    pending_.push_back(item);
    return Status::Ok();
  }

  Status ParsePointEdge(const LineReader& reader, PendingKind kind) {
    const bool observation = kind == PendingKind::kPointObservation;
    const size_t first = observation ? 4 : 2;  // first measurement field
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(first + 3 + 6));
    Pending item;
    item.kind = kind;
    item.line = reader.line_number();
    GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "pose id"));
    if (observation) {
      GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "point id"));
      GS_ASSIGN_OR_RETURN(item.param, reader.Id(3, "offset parameter id"));
      if (const auto it = offsets_.find(item.param); it != offsets_.end() && !it->second) {
        return reader.Unsupported("EDGE_SE3_TRACKXYZ uses PARAMS_SE3OFFSET " +
                                  std::to_string(item.param) +
                                  ", which is not the identity; expected an identity offset");
      }
    }
    double z[3], upper[6];
    GS_RETURN_IF_ERROR(reader.Doubles(first, 3, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(first + 3, 6, "information", upper,
                                       internal::Magnitude::kInformation));
    item.point = Eigen::Vector3d(z[0], z[1], z[2]);
    item.information3 = internal::SymmetricFromUpper<3>(upper);
    if (!internal::IsPositiveDefiniteMatrix(item.information3))
      return reader.Error(std::string(PendingTag(kind)) + " information " +
                          internal::UpperTriangleString(upper, 6) +
                          " is not positive definite; expected a symmetric positive definite "
                          "3x3 matrix");
    pending_.push_back(item);
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

  Status ParseFix(const LineReader& reader) {
    std::vector<int64_t> ids;
    GS_RETURN_IF_ERROR(internal::ReadFixIds(reader, &ids));
    for (const int64_t id : ids) {
      Pending item;
      item.kind = PendingKind::kFix;
      item.line = reader.line_number();
      item.ids[0] = id;
      pending_.push_back(item);
    }
    return Status::Ok();
  }

  StatusOr<int32_t> Lookup(int64_t id, VertexKind kind, const Pending& item) {
    return vertices_.Lookup(name_, item.line, PendingTag(item.kind), id, kind,
                            [this, id](VertexKind created) {
                              return created == VertexKind::kPose
                                         ? problem_.AddPose(id, core::Pose3::Identity(), false, 0)
                                         : problem_.AddFeature(id, core::Point3::Zero(), false);
                            });
  }

  Status Resolve(const Pending& item) {
    switch (item.kind) {
      case PendingKind::kRelativePose: {
        core::RelativePose3Constraint c;
        GS_ASSIGN_OR_RETURN(c.from, Lookup(item.ids[0], VertexKind::kPose, item));
        GS_ASSIGN_OR_RETURN(c.to, Lookup(item.ids[1], VertexKind::kPose, item));
        c.z = item.pose;
        c.information = item.information6;
        c.line = item.line;
        problem_.relative_poses.push_back(c);
        return Status::Ok();
      }
      case PendingKind::kPointObservation: {
        core::Point3Observation o;
        GS_ASSIGN_OR_RETURN(o.pose, Lookup(item.ids[0], VertexKind::kPose, item));
        GS_ASSIGN_OR_RETURN(o.feature, Lookup(item.ids[1], VertexKind::kFeature, item));
        o.z = item.point;
        o.information = item.information3;
        o.line = item.line;
        problem_.observations.push_back(o);
        return Status::Ok();
      }
      case PendingKind::kGps: {
        core::Gps3Constraint g;
        GS_ASSIGN_OR_RETURN(g.pose, Lookup(item.ids[0], VertexKind::kPose, item));
        g.z = item.point;
        g.information = item.information3;
        g.line = item.line;
        problem_.gps.push_back(g);
        return Status::Ok();
      }
      case PendingKind::kFix: {
        GS_ASSIGN_OR_RETURN(const int32_t p, Lookup(item.ids[0], VertexKind::kPose, item));
        problem_.pose_fixed[p] = 1;
        return Status::Ok();
      }
    }
    return Status::Ok();
  }

  std::string path_;
  std::string name_;
  core::Problem3d problem_;
  internal::G2oVertices vertices_{"VERTEX_SE3:QUAT", "VERTEX_TRACKXYZ"};
  std::unordered_map<int64_t, bool> offsets_;  // id -> is identity
  std::vector<Pending> pending_;
};

}  // namespace

StatusOr<core::Problem3d> ReadG2o3d(const std::string& path) { return G2o3dParser(path).Parse(); }

}  // namespace graphslam::storage
