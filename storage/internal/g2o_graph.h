// The part of reading a g2o graph that does not depend on the dimension,
// shared by the 2-D (storage/g2o_reader.cc) and the 3-D
// (storage/g2o_3d_reader.cc) readers as one template over a Graph traits
// struct (G2o2d, G2o3d below):
//   - the read loop: every line to the reader's own ParseLine, then the
//     "has no vertices or edges" check;
//   - the pending edges: relative poses, point observations, position priors
//     and FIX, kept with their file ids until every vertex is known (g2o lets
//     edges come before their vertices; internal/g2o_vertices.h), then
//     resolved into the problem in file order.
// Each reader keeps what differs: its tags, the vertex and edge lines' fields
// (SE(2) x y theta vs SE(3) x y z quaternion) and their messages.
//
// THREAD SAFETY: one graph per reader. ALLOCATION: one entry per edge until
// Finish.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/status.h"
#include "storage/internal/g2o_vertices.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage::internal {

enum class G2oEdgeKind { kRelativePose, kPointObservation, kPositionPrior, kFix };

// EDGE_SE2, EDGE_SE2_XY, EDGE_PRIOR_SE2_XY, VERTEX_SE2 / VERTEX_XY.
struct G2o2d {
  using Problem = core::Problem2d;
  using Pose = core::Pose2;
  using Point = core::Point2;
  using PoseInformation = Eigen::Matrix3d;
  using PointInformation = Eigen::Matrix2d;
  using RelativePose = core::RelativePoseConstraint;
  using PointObservation = core::Observation;
  using PositionPrior = core::GpsConstraint;
  static constexpr const char* kEdgeTags[4] = {"EDGE_SE2", "EDGE_SE2_XY", "EDGE_PRIOR_SE2_XY",
                                               "FIX"};
  static constexpr const char* kPoseVertexTag = "VERTEX_SE2";
  static constexpr const char* kPointVertexTag = "VERTEX_XY";
  static constexpr const char* kWhat = "a g2o graph";
  static Pose UnknownPose() { return Pose::Zero(); }
  static void SetKind(PointObservation* o) { o->kind = core::ObservationKind::kPointXY; }
};

// EDGE_SE3:QUAT, EDGE_SE3_TRACKXYZ, EDGE_SE3_XYZPRIOR, VERTEX_SE3:QUAT /
// VERTEX_TRACKXYZ.
struct G2o3d {
  using Problem = core::Problem3d;
  using Pose = core::Pose3;
  using Point = core::Point3;
  using PoseInformation = core::Matrix6d;
  using PointInformation = Eigen::Matrix3d;
  using RelativePose = core::RelativePose3Constraint;
  using PointObservation = core::Point3Observation;
  using PositionPrior = core::Gps3Constraint;
  static constexpr const char* kEdgeTags[4] = {"EDGE_SE3:QUAT", "EDGE_SE3_TRACKXYZ",
                                               "EDGE_SE3_XYZPRIOR", "FIX"};
  static constexpr const char* kPoseVertexTag = "VERTEX_SE3:QUAT";
  static constexpr const char* kPointVertexTag = "VERTEX_TRACKXYZ";
  static constexpr const char* kWhat = "a 3-D g2o graph";
  static Pose UnknownPose() { return Pose::Identity(); }
  static void SetKind(PointObservation*) {}  // one 3-D observation model
};

template <class Graph>
class G2oGraph {
 public:
  using Problem = typename Graph::Problem;

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

  std::string name_;
  Problem problem_;
  G2oVertices vertices_{Graph::kPoseVertexTag, Graph::kPointVertexTag};
  std::vector<Pending> pending_;
};

}  // namespace graphslam::storage::internal
