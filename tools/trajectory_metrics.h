// Accuracy of an estimated trajectory and map against ground truth: the
// absolute trajectory error (ATE) of Sturm et al., "A Benchmark for the
// Evaluation of RGB-D SLAM Systems" (IROS 2012), in 2-D, plus the landmark
// position error.
//
// GraphSLAM fixes the map only up to a rigid motion when nothing anchors it
// absolutely (no GPS), so errors are measured after the rigid alignment
// T = (R, t) minimizing
//
//   sum_i | R p_i + t - q_i |^2        p_i estimated, q_i true (x, y)
//
// (Umeyama, "Least-squares estimation of transformation parameters between two
// point patterns", PAMI 1991, without scaling; Eigen::umeyama). Then
//
//   position RMSE = sqrt( 1/n sum_i | R p_i + t - q_i |^2 )
//   heading  RMSE = sqrt( 1/n sum_i wrap(theta_i + angle(R) - theta*_i)^2 )
//   landmark RMSE = sqrt( 1/m sum_j | R m_j + t - m*_j |^2 )  (features matched by id)
//
// The landmark RMSE is reported twice: with the trajectory's T (the map as
// the trajectory places it) and with its own alignment of the features.
//
// Matching poses: by time stamp. A file may hold several runs one after
// another; a stamp smaller than its predecessor starts a new run (the
// simulator's stamps restart at 0 with every run). Run r of the estimate is
// matched with run r of the ground truth; each estimated pose takes the
// ground-truth pose nearest in time (binary search), and is skipped when that
// is farther than max_time_difference (default: the smaller of 0.05 s and
// half the median ground-truth spacing).
//
// THREAD SAFETY: pure functions / reentrant readers.
// ALLOCATION: O(poses + features).
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/se2.h"
#include "core/status.h"

namespace graphslam::tools {

struct StampedPose2 {
  double stamp = 0.0;  // s
  core::Pose2 pose = core::Pose2::Zero();
};

// Reads a TUM trajectory (storage/tum_reader.h: "t x y z qx qy qz qw" per
// line, errors "<file>:<line>: ...") as planar poses: z is ignored, theta is
// the yaw of the quaternion (storage/stamped_pose.h, ProjectToPlane).
StatusOr<std::vector<StampedPose2>> ReadTum(const std::string& path);

// Reads a feature CSV as storage/features_csv_writer.h writes it
// ("id,x,y,observations,excluded"; the header line and the last two columns
// are optional). Rows marked excluded = 1 (features the solver dropped) are
// left out of the map and, if `excluded_ids` is given, listed there.
// Corruption "<file>:<line>: ..." for fewer than 3 fields, a bad number, or a
// duplicate id (naming the line of the first one).
StatusOr<std::map<int64_t, core::Point2>> ReadFeaturesCsv(
    const std::string& path, std::vector<int64_t>* excluded_ids = nullptr);

// The rigid T minimizing sum |T source_i - target_i|^2 (Umeyama, no scale).
// Both vectors must have the same size (GS_CHECK). With 0 points: identity;
// with 1 point: the translation only.
Eigen::Isometry2d AlignRigid(const std::vector<core::Point2>& source,
                             const std::vector<core::Point2>& target);

// The rotation angle of a 2-D isometry.
double RotationAngle(const Eigen::Isometry2d& transform);

struct TrajectoryMatchOptions {
  double max_time_difference = -1.0;  // s; < 0: min(0.05, median GT spacing / 2)
  bool align = true;                  // false: compare in the given frames
};

struct TrajectoryErrors {
  int64_t matched = 0;    // estimated poses with a ground-truth partner
  int64_t unmatched = 0;  // estimated poses skipped (no ground truth near in time)
  int64_t runs = 0;
  double max_time_difference = 0.0;  // s, the tolerance used
  double position_rmse = 0.0;        // m, after alignment
  double heading_rmse_rad = 0.0;
  double position_max = 0.0;   // m, the largest position error
  double position_mean = 0.0;  // m
  // Maps estimated coordinates into the ground-truth frame.
  Eigen::Isometry2d alignment = Eigen::Isometry2d::Identity();
  // The matched pairs, in estimated order (for plots and feature alignment).
  std::vector<int64_t> estimated_index;
  std::vector<int64_t> ground_truth_index;
};

// InvalidArgument when the estimate and ground truth hold different numbers of
// runs, when the ground truth is empty, or when no pose could be matched.
StatusOr<TrajectoryErrors> CompareTrajectories(const std::vector<StampedPose2>& estimated,
                                               const std::vector<StampedPose2>& ground_truth,
                                               const TrajectoryMatchOptions& options = {});

// Several runs in ONE frame (a multi-robot map) against their ground truths,
// after ONE rigid alignment T of all runs together: each run's poses are
// matched to its own ground truth by time (as CompareTrajectories), T is
// AlignRigid over the matched positions of all runs, and every error uses T.
// A run mapped in a wrong place relative to the others therefore shows up in
// its error, which a per-run alignment would hide.
struct JointTrajectoryErrors {
  Eigen::Isometry2d alignment = Eigen::Isometry2d::Identity();  // estimate -> truth
  std::vector<TrajectoryErrors> runs;  // per run, all with `alignment`
  int64_t matched = 0;
  double position_rmse = 0.0;     // m, over every matched pose of every run
  double heading_rmse_rad = 0.0;
};

// `estimated[r]` is matched with `ground_truth[r]` (one run each).
// InvalidArgument when the sizes differ, a ground truth is empty or a run has
// no pose matched (the message names the run index).
StatusOr<JointTrajectoryErrors> CompareTrajectoriesJointly(
    const std::vector<std::vector<StampedPose2>>& estimated,
    const std::vector<std::vector<StampedPose2>>& ground_truth,
    const TrajectoryMatchOptions& options = {});

// RMSE of |T m_id - m*_id| over the ids in both maps; NaN when none match.
// `matched`, if given, receives the number of common ids.
double FeatureRmse(const std::map<int64_t, core::Point2>& estimated,
                   const std::map<int64_t, core::Point2>& ground_truth,
                   const Eigen::Isometry2d& estimated_to_ground_truth,
                   int64_t* matched = nullptr);

struct FeatureErrors {
  int64_t matched = 0;
  int64_t missing = 0;  // in the ground truth, not in the estimate
  int64_t extra = 0;    // in the estimate, not in the ground truth
  double rmse_trajectory_aligned = 0.0;  // m, with the trajectory's alignment
  double rmse_self_aligned = 0.0;        // m, with the features' own alignment
  Eigen::Isometry2d self_alignment = Eigen::Isometry2d::Identity();
};

// Both RMSEs (NaN when no id matches).
FeatureErrors CompareFeatures(const std::map<int64_t, core::Point2>& estimated,
                              const std::map<int64_t, core::Point2>& ground_truth,
                              const Eigen::Isometry2d& trajectory_alignment);

}  // namespace graphslam::tools
