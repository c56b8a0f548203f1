// The part of reading a g2o graph that does not depend on the dimension,
// shared by the 2-D (storage/g2o_reader.cc) and the 3-D
// (storage/g2o_3d_reader.cc) readers as one template over a Graph traits
// struct (G2oFormat<Space>: G2o2d, G2o3d below):
//   - the read loop: every line to the reader's own ParseLine, then the
//     "has no vertices or edges" check;
//   - the pending edges: relative poses, point observations, position priors
//     and FIX, kept with their file ids until every vertex is known (g2o lets
//     edges come before their vertices; internal/g2o_vertices.h), then
//     resolved into the problem in file order.
// The vertex and edge records both dimensions share are parsed in
// internal/g2o_records.h from the sizes, pose reader and message forms of the
// traits, dispatched by tag in internal/g2o_parser.h, and written back by
// internal/g2o_record_writer.h. Each reader keeps what only it has (its
// Dialect): 2-D DATA_FEATURE_POINTXY, 3-D PARAMS_SE3OFFSET.
//
// THREAD SAFETY: one graph per reader. ALLOCATION: one entry per edge until
// Finish.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "core/information_repair.h"
#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/problem_space.h"
#include "core/status.h"
#include "storage/internal/g2o_vertices.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage::internal {

enum class G2oEdgeKind { kRelativePose, kPointObservation, kPositionPrior, kFix };

// The types of a graph's traits, from the problem of its space
// (core/problem_space.h: Space::Problem; core/problem_unknowns.h).
template <class Space>
struct G2oTypes {
  using Problem = typename Space::Problem;
  using Pose = typename Problem::Pose;
  using Point = typename Problem::Point;
  using RelativePose = typename decltype(Problem::relative_poses)::value_type;
  using PointObservation = typename decltype(Problem::observations)::value_type;
  using PositionPrior = typename decltype(Problem::gps)::value_type;
  using PoseInformation = decltype(RelativePose::information);
  using PointInformation = decltype(PointObservation::information);
  static Pose UnknownPose() { return core::IdentityPose<Pose>(); }
};

// The g2o records of a problem space, as small specializations: the tags,
// the pose fields and the message forms. The readers and the writers are
// templates over these (internal/g2o_records.h, internal/g2o_parser.h,
// internal/g2o_record_writer.h), as the solver is over the Space.
template <class Space>
struct G2oFormat;

// EDGE_SE2, EDGE_SE2_XY, EDGE_PRIOR_SE2_XY, VERTEX_SE2 / VERTEX_XY.
template <>
struct G2oFormat<core::Space2d> : G2oTypes<core::Space2d> {
  static constexpr const char* kEdgeTags[4] = {"EDGE_SE2", "EDGE_SE2_XY", "EDGE_PRIOR_SE2_XY",
                                               "FIX"};
  static constexpr const char* kPoseVertexTag = "VERTEX_SE2";
  static constexpr const char* kPointVertexTag = "VERTEX_XY";
  static constexpr const char* kWhat = "a g2o graph";
  static constexpr const char* kFeatureIdName = "landmark id";
  static constexpr const char* kPoseInformationForm = "matrix (upper triangle xx xy xt yy yt tt)";
  static constexpr const char* kPointInformationForm = "matrix (upper triangle xx xy yy)";
  static constexpr int kPoseFields = 3;  // x y theta
  static StatusOr<Pose> ReadPose(const LineReader& reader, size_t first, std::string_view what) {
    double v[kPoseFields];
    GS_RETURN_IF_ERROR(reader.Doubles(first, kPoseFields, what, v));
    return Pose(v[0], v[1], v[2]);
  }
  static void SetKind(PointObservation* o) { o->kind = core::ObservationKind::kPointXY; }
  static constexpr size_t kPointEdgeExtraFields = 0;
  // The fields ReadPose reads (internal/g2o_record_writer.h).
  static void AppendPose(std::string* line, const Pose& pose) {
    for (int k = 0; k < kPoseFields; ++k) AppendField(line, pose[k]);
  }
};

// EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ, EDGE_SE3_XYZPRIOR, VERTEX_SE3:QUAT /
// VERTEX_TRACKXYZ.
template <>
struct G2oFormat<core::Space3d> : G2oTypes<core::Space3d> {
  static constexpr const char* kEdgeTags[4] = {"EDGE_SE3:QUAT", "EDGE_SE3_TRACKXYZ",
                                               "EDGE_SE3_XYZPRIOR", "FIX"};
  static constexpr const char* kPoseVertexTag = "VERTEX_SE3:QUAT";
  static constexpr const char* kPointVertexTag = "VERTEX_TRACKXYZ";
  static constexpr const char* kWhat = "a 3-D g2o graph";
  static constexpr const char* kFeatureIdName = "point id";
  static constexpr const char* kPoseInformationForm = "6x6 matrix";
  static constexpr const char* kPointInformationForm = "3x3 matrix";
  static constexpr int kPoseFields = 7;  // x y z qx qy qz qw
  // The quaternion is normalized (files carry ~7 digits); a norm outside
  // [0.9, 1.1] is an error.
  static StatusOr<Pose> ReadPose(const LineReader& reader, size_t first, std::string_view what) {
    double v[kPoseFields];
    GS_RETURN_IF_ERROR(reader.Doubles(first, kPoseFields, what, v));
    Pose pose;
    pose.t = Eigen::Vector3d(v[0], v[1], v[2]);
    pose.q = Eigen::Quaterniond(v[6], v[3], v[4], v[5]);
    const double norm = pose.q.norm();
    if (!(norm >= 0.9 && norm <= 1.1)) {
      return reader.Error(std::string(what) + " quaternion has norm " + FormatDouble(norm) +
                          "; expected a unit quaternion (qx qy qz qw)");
    }
    pose.q.normalize();
    return pose;
  }
  static void SetKind(PointObservation*) {}  // one 3-D observation model
  // EDGE_SE3_TRACKXYZ carries the id of its sensor offset (PARAMS_SE3OFFSET)
  // between the ids and the measurement.
  static constexpr size_t kPointEdgeExtraFields = 1;
  // The fields ReadPose reads, the quaternion normalized with qw >= 0.
  static void AppendPose(std::string* line, const Pose& pose) {
    Eigen::Quaterniond q = pose.q.normalized();
    if (q.w() < 0.0) q.coeffs() = -q.coeffs();
    for (int k = 0; k < 3; ++k) AppendField(line, pose.t[k]);
    AppendField(line, q.x());
    AppendField(line, q.y());
    AppendField(line, q.z());
    AppendField(line, q.w());
  }
};

using G2o2d = G2oFormat<core::Space2d>;
using G2o3d = G2oFormat<core::Space3d>;

template <class Graph>
class G2oGraph {
 public:
  using Problem = typename Graph::Problem;

  // With `repairs` (opt-in), information that is not positive definite is
  // repaired and counted there instead of rejected (internal/g2o_records.h).
  explicit G2oGraph(core::InformationRepairs* repairs = nullptr) : repairs_(repairs) {}

  // An edge or FIX with its file ids.
  struct Pending {
    G2oEdgeKind kind = G2oEdgeKind::kFix;
    int64_t ids[2] = {0, 0};
    int32_t line = 0;
    typename Graph::Pose pose = Graph::UnknownPose();
    typename Graph::Point point = Graph::Point::Zero();
    typename Graph::PoseInformation pose_information = Graph::PoseInformation::Identity();
    typename Graph::PointInformation point_information = Graph::PointInformation::Identity();
  };

  static const char* Tag(G2oEdgeKind kind) { return Graph::kEdgeTags[static_cast<int>(kind)]; }

  // Reads `path`, calling parse_line(reader) for every record, then resolves
  // the pending edges. Errors: the reader's, or Corruption for an empty graph.
  template <class ParseLine>
  StatusOr<Problem> Read(const std::string& path, ParseLine&& parse_line) {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(path));
    name_ = reader->name();
    problem_.source = path;
    while (reader->Next()) GS_RETURN_IF_ERROR(parse_line(*reader));
    GS_RETURN_IF_ERROR(reader->status());
    if (vertices_.empty() && pending_.empty())
      return Status::Corruption(name_ + ": has no vertices or edges; expected " + Graph::kWhat);
    vertices_.Seal();
    for (const Pending& item : pending_) GS_RETURN_IF_ERROR(Resolve(item));
    return std::move(problem_);
  }

  Problem& problem() { return problem_; }
  core::InformationRepairs* repairs() const { return repairs_; }
  G2oVertices& vertices() { return vertices_; }
  void Add(const Pending& item) { pending_.push_back(item); }

  // FIX id [id ...]: one pending FIX per id.
  Status AddFix(const LineReader& reader) {
    std::vector<int64_t> ids;
    GS_RETURN_IF_ERROR(ReadFixIds(reader, &ids));
    for (const int64_t id : ids) {
      Pending item;
      item.kind = G2oEdgeKind::kFix;
      item.line = reader.line_number();
      item.ids[0] = id;
      pending_.push_back(item);
    }
    return Status::Ok();
  }

 private:
  // The dense index of vertex `id`, which must be of `kind`; creates it in
  // edges-only files.
  StatusOr<int32_t> Lookup(int64_t id, G2oVertexKind kind, const Pending& item) {
    return vertices_.Lookup(name_, item.line, Tag(item.kind), id, kind,
                            [this, id](G2oVertexKind created) {
                              return created == G2oVertexKind::kPose
                                         ? problem_.AddPose(id, Graph::UnknownPose(),
                                                            /*initialized=*/false, 0)
                                         : problem_.AddFeature(id, Graph::Point::Zero(),
                                                               /*initialized=*/false);
                            });
  }

  Status Resolve(const Pending& item) {
    switch (item.kind) {
      case G2oEdgeKind::kRelativePose: {
        typename Graph::RelativePose c;
        GS_ASSIGN_OR_RETURN(c.from, Lookup(item.ids[0], G2oVertexKind::kPose, item));
        GS_ASSIGN_OR_RETURN(c.to, Lookup(item.ids[1], G2oVertexKind::kPose, item));
        c.z = item.pose;
        c.information = item.pose_information;
        c.line = item.line;
        problem_.relative_poses.push_back(c);
        return Status::Ok();
      }
      case G2oEdgeKind::kPointObservation: {
        typename Graph::PointObservation o;
        GS_ASSIGN_OR_RETURN(o.pose, Lookup(item.ids[0], G2oVertexKind::kPose, item));
        GS_ASSIGN_OR_RETURN(o.feature, Lookup(item.ids[1], G2oVertexKind::kFeature, item));
        Graph::SetKind(&o);
        o.z = item.point;
        o.information = item.point_information;
        o.line = item.line;
        problem_.observations.push_back(o);
        return Status::Ok();
      }
      case G2oEdgeKind::kPositionPrior: {
        typename Graph::PositionPrior g;
        GS_ASSIGN_OR_RETURN(g.pose, Lookup(item.ids[0], G2oVertexKind::kPose, item));
        g.z = item.point;
        g.information = item.point_information;
        g.line = item.line;
        problem_.gps.push_back(g);
        return Status::Ok();
      }
      case G2oEdgeKind::kFix: {
        // FIX names vertices: in a file with vertices a FIX of an unknown id
        // is an error like any edge; fixing a landmark is not supported.
        GS_ASSIGN_OR_RETURN(const int32_t pose, Lookup(item.ids[0], G2oVertexKind::kPose, item));
        problem_.pose_fixed[pose] = 1;
        return Status::Ok();
      }
    }
    return Status::Ok();
  }

  core::InformationRepairs* const repairs_;  // null: reject non-PD information
  std::string name_;
  Problem problem_;
  G2oVertices vertices_{Graph::kPoseVertexTag, Graph::kPointVertexTag};
  std::vector<Pending> pending_;
};

}  // namespace graphslam::storage::internal
