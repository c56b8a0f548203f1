// The g2o records whose layout is the same in 2-D and 3-D but for the sizes,
// parsed once over the Graph traits of internal/g2o_graph.h (G2o2d, G2o3d)
// for storage/g2o_reader.cc and storage/g2o_3d_reader.cc:
//
//   pose vertex    TAG id <pose>                          (kPoseFields numbers)
//   point vertex   TAG id <point>                         (kPointDim numbers)
//   relative pose  TAG i j <pose> Omega(upper triangle)
//   point edge     TAG i [l [extra]] <point> Omega(upper)  (observation; prior without l)
//
// <pose> is read by Graph::ReadPose (x y theta; x y z qx qy qz qw). Omega is
// the upper triangle of the information matrix, row first (g2o). Information
// that is not positive definite is repaired and counted when the graph was
// given InformationRepairs (core/information_repair.h, opt-in), else a
// Corruption "<tag> information [...] is not positive definite; expected a
// symmetric positive definite <Graph's form>". An edge from a vertex to
// itself is a Corruption. The records are checked in the order fields,
// ids, measurement, information, self-loop, so the first error of a line is
// the same in both dimensions.
//
// THREAD SAFETY: as the graph. ALLOCATION: one pending entry per edge.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <string_view>

#include "core/status.h"
#include "storage/internal/g2o_graph.h"
#include "storage/internal/text_reader.h"
#include "storage/internal/upper_triangle.h"

namespace graphslam::storage::internal {

// The N x N information matrix whose upper triangle starts at field `first`.
template <int N>
Status ReadG2oInformation(const LineReader& reader, size_t first, std::string_view tag,
                          std::string_view form, core::InformationRepairs* repairs,
                          Eigen::Matrix<double, N, N>* information) {
  constexpr int kCount = N * (N + 1) / 2;
  double upper[kCount];
  GS_RETURN_IF_ERROR(reader.Doubles(first, kCount, "information", upper, Magnitude::kInformation));
  *information = SymmetricFromUpper<N>(upper);
  if (IsPositiveDefiniteMatrix(*information) ||
      core::RepairAndCount(repairs, reader.line_number(), information))
    return Status::Ok();
  return reader.Error(std::string(tag) + " information " + UpperTriangleString(upper, kCount) +
                      " is not positive definite; expected a symmetric positive definite " +
                      std::string(form));
}

// Returns the dense index of the new pose.
template <class Graph>
StatusOr<int32_t> ParseG2oPoseVertex(const LineReader& reader, G2oGraph<Graph>* graph) {
  GS_RETURN_IF_ERROR(reader.ExpectFieldCount(2 + Graph::kPoseFields));
  GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
  GS_ASSIGN_OR_RETURN(const typename Graph::Pose pose, Graph::ReadPose(reader, 2, "estimate"));
  GS_RETURN_IF_ERROR(graph->vertices().CheckUnique(reader, id, G2oVertexKind::kPose));
  const int32_t index =
      graph->problem().AddPose(id, pose, /*initialized=*/true, reader.line_number());
  graph->vertices().Define(id, G2oVertexKind::kPose, index, reader.line_number());
  return index;
}

template <class Graph>
Status ParseG2oPointVertex(const LineReader& reader, G2oGraph<Graph>* graph) {
  using Point = typename Graph::Point;
  GS_RETURN_IF_ERROR(reader.ExpectFieldCount(2 + Point::RowsAtCompileTime));
  GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
  double values[Point::RowsAtCompileTime];
  GS_RETURN_IF_ERROR(reader.Doubles(2, Point::RowsAtCompileTime, "estimate", values));
  GS_RETURN_IF_ERROR(graph->vertices().CheckUnique(reader, id, G2oVertexKind::kFeature));
  const int32_t index =
      graph->problem().AddFeature(id, Eigen::Map<const Point>(values), /*initialized=*/true);
  graph->vertices().Define(id, G2oVertexKind::kFeature, index, reader.line_number());
  return Status::Ok();
}

template <class Graph>
Status ParseG2oRelativePose(const LineReader& reader, G2oGraph<Graph>* graph) {
  using Information = typename Graph::PoseInformation;
  constexpr int kDim = Information::RowsAtCompileTime;
  GS_RETURN_IF_ERROR(reader.ExpectFieldCount(3 + Graph::kPoseFields + kDim * (kDim + 1) / 2));
  typename G2oGraph<Graph>::Pending item;
  item.kind = G2oEdgeKind::kRelativePose;
  item.line = reader.line_number();
  const char* tag = G2oGraph<Graph>::Tag(item.kind);
  GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "from id"));
  GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "to id"));
  GS_ASSIGN_OR_RETURN(item.pose, Graph::ReadPose(reader, 3, "measurement"));
  GS_RETURN_IF_ERROR(ReadG2oInformation<kDim>(reader, 3 + Graph::kPoseFields, tag,
                                              Graph::kPoseInformationForm, graph->repairs(),
                                              &item.pose_information));
  if (item.ids[0] == item.ids[1]) {
    return reader.Error(std::string(tag) + " connects vertex " + std::to_string(item.ids[0]) +
                        " to itself; expected two distinct vertices");
  }
  graph->Add(item);
  return Status::Ok();
}

// kPointObservation: TAG pose feature [extra_fields] <point> Omega, where
// check_extra(reader) validates the extra fields (3-D: the sensor offset);
// kPositionPrior: TAG pose <point> Omega.
template <class Graph, class CheckExtra>
Status ParseG2oPointEdge(const LineReader& reader, G2oEdgeKind kind, size_t extra_fields,
                         G2oGraph<Graph>* graph, CheckExtra&& check_extra) {
  using Point = typename Graph::Point;
  constexpr int kDim = Point::RowsAtCompileTime;
  const bool observation = kind == G2oEdgeKind::kPointObservation;
  const size_t first = observation ? 3 + extra_fields : 2;  // the first measurement field
  GS_RETURN_IF_ERROR(reader.ExpectFieldCount(first + kDim + kDim * (kDim + 1) / 2));
  typename G2oGraph<Graph>::Pending item;
  item.kind = kind;
  item.line = reader.line_number();
  GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "pose id"));
  if (observation) {
    GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, Graph::kFeatureIdName));
    GS_RETURN_IF_ERROR(check_extra(reader));
  }
  double z[kDim];
  GS_RETURN_IF_ERROR(reader.Doubles(first, kDim, "measurement", z));
  item.point = Eigen::Map<const Point>(z);
  GS_RETURN_IF_ERROR(ReadG2oInformation<kDim>(reader, first + kDim, G2oGraph<Graph>::Tag(kind),
                                              Graph::kPointInformationForm, graph->repairs(),
                                              &item.point_information));
  graph->Add(item);
  return Status::Ok();
}

}  // namespace graphslam::storage::internal
