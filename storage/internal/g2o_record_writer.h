// Writes the g2o records both dimensions share, the reverse of
// internal/g2o_records.h, once over the Graph traits of internal/g2o_graph.h
// (G2o2d, G2o3d) for storage/g2o_writer.cc and storage/g2o_3d_writer.cc:
//
//   pose vertex     TAG id <pose>                          every pose, index order
//   point vertex    TAG (id + offset) <point>              every feature, index order
//   FIX id                                                 every fixed pose
//   relative pose   TAG i j <pose> Omega(upper triangle)
//   point edge      TAG i (l + offset) [0 ...] <point> Omega(upper triangle)
//   position prior  TAG i <point> Omega(upper triangle)
//
// <pose> is Graph::AppendPose (x y theta; x y z qx qy qz qw), Omega the upper
// triangle of the information matrix, row first; numbers "%.17g"
// (internal/text_reader.h: AppendField), so they read back bit-identical.
// `offset` renumbers the features (2-D: storage/g2o_writer.h); the point
// edge's Graph::kPointEdgeExtraFields fields are 0 (3-D: the identity sensor
// offset its writer declares). Each writer keeps its own conversions (2-D:
// range-bearing to a point, velocity motion to a relative pose).
//
// THREAD SAFETY: one writer per file. ALLOCATION: one line buffer.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/status.h"
#include "storage/env.h"
#include "storage/internal/g2o_graph.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage::internal {

template <class Graph>
class G2oRecordWriter {
 public:
  using Problem = typename Graph::Problem;
  using Pose = typename Graph::Pose;
  using Point = typename Graph::Point;

  G2oRecordWriter(WritableFile* file, const Problem& problem, int64_t feature_id_offset = 0)
      : file_(file), problem_(problem), offset_(feature_id_offset) {}

  // One line as given (a comment, a parameter record).
  Status Line(std::string_view text) {
    line_.append(text);
    return Flush();
  }

  // The pose vertices, the point vertices, then FIX for every fixed pose.
  Status Vertices() {
    for (int32_t i = 0; i < problem_.num_poses(); ++i) {
      AppendField(&line_, Graph::kPoseVertexTag);
      AppendField(&line_, problem_.pose_ids[i]);
      Graph::AppendPose(&line_, problem_.poses[i]);
      GS_RETURN_IF_ERROR(Flush());
    }
    for (int32_t i = 0; i < problem_.num_features(); ++i) {
      AppendField(&line_, Graph::kPointVertexTag);
      AppendField(&line_, problem_.feature_ids[i] + offset_);
      AppendPoint(problem_.features[i]);
      GS_RETURN_IF_ERROR(Flush());
    }
    for (int32_t i = 0; i < problem_.num_poses(); ++i) {
      if (!problem_.pose_fixed[i]) continue;
      AppendField(&line_, Tag(G2oEdgeKind::kFix));
      AppendField(&line_, problem_.pose_ids[i]);
      GS_RETURN_IF_ERROR(Flush());
    }
    return Status::Ok();
  }

  Status RelativePose(int32_t from, int32_t to, const Pose& z,
                      const typename Graph::PoseInformation& information) {
    AppendField(&line_, Tag(G2oEdgeKind::kRelativePose));
    AppendField(&line_, problem_.pose_ids[from]);
    AppendField(&line_, problem_.pose_ids[to]);
    Graph::AppendPose(&line_, z);
    AppendUpper(information);
    return Flush();
  }
  Status RelativePoses() {
    for (const auto& c : problem_.relative_poses)
      GS_RETURN_IF_ERROR(RelativePose(c.from, c.to, c.z, c.information));
    return Status::Ok();
  }

  Status PointObservation(int32_t pose, int32_t feature, const Point& z,
                          const typename Graph::PointInformation& information) {
    AppendField(&line_, Tag(G2oEdgeKind::kPointObservation));
    AppendField(&line_, problem_.pose_ids[pose]);
    AppendField(&line_, problem_.feature_ids[feature] + offset_);
    for (size_t k = 0; k < Graph::kPointEdgeExtraFields; ++k) AppendField(&line_, int64_t{0});
    AppendPoint(z);
    AppendUpper(information);
    return Flush();
  }

  Status PositionPriors() {
    for (const auto& prior : problem_.gps) {
      AppendField(&line_, Tag(G2oEdgeKind::kPositionPrior));
      AppendField(&line_, problem_.pose_ids[prior.pose]);
      AppendPoint(prior.z);
      AppendUpper(prior.information);
      GS_RETURN_IF_ERROR(Flush());
    }
    return Status::Ok();
  }

 private:
  static const char* Tag(G2oEdgeKind kind) { return Graph::kEdgeTags[static_cast<int>(kind)]; }

  void AppendPoint(const Point& point) {
    for (int k = 0; k < Point::RowsAtCompileTime; ++k) AppendField(&line_, point[k]);
  }
  template <class Matrix>
  void AppendUpper(const Matrix& m) {
    for (int r = 0; r < m.rows(); ++r)
      for (int c = r; c < m.cols(); ++c) AppendField(&line_, m(r, c));
  }
  // Ends the line, appends it to the file and clears it.
  Status Flush() {
    line_.push_back('\n');
    Status status = file_->Append(line_);
    line_.clear();
    return status;
  }

  WritableFile* const file_;
  const Problem& problem_;
  const int64_t offset_;
  std::string line_;
};

}  // namespace graphslam::storage::internal
