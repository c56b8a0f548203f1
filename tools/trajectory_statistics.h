// Error statistics of a trajectory against ground truth, as evo and the TUM /
// KITTI benchmarks report them, on the pose pairs CompareTrajectories matched
// (tools/trajectory_metrics.h).
//
// Absolute trajectory error (ATE), Sturm et al. (IROS 2012), per matched pair
//   e_k = | R p_k + t - q_k |            p estimated, q true, (R, t) the alignment
// Relative pose error (RPE) over a travelled distance delta, Geiger et al.
// (KITTI, CVPR 2012): for every matched pair k, l(k) is the first later pair
// whose ground truth has travelled at least delta further along its path, and
//   E_k = (Q_k^-1 Q_l)^-1 (P_k^-1 P_l)    translation error |t(E_k)|, rotation |theta(E_k)|
// RPE needs no alignment: it compares motions, each in its own start frame.
//
// Statistics of n errors: RMSE sqrt(1/n sum e^2), mean, median (mean of the
// two middle values for even n), standard deviation (population, 1/n, as evo)
// and maximum; all NaN (count 0) for no error.
//
// THREAD SAFETY: pure functions. ALLOCATION: O(poses).
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "tools/trajectory_metrics.h"

namespace graphslam::tools {

struct ErrorStatistics {
  int64_t count = 0;
  double rmse = std::numeric_limits<double>::quiet_NaN();
  double mean = std::numeric_limits<double>::quiet_NaN();
  double median = std::numeric_limits<double>::quiet_NaN();
  double std = std::numeric_limits<double>::quiet_NaN();
  double max = std::numeric_limits<double>::quiet_NaN();
};

ErrorStatistics Summarize(std::vector<double> errors);

struct AbsoluteErrors {
  std::vector<double> stamps;    // s, of the estimated poses
  std::vector<double> position;  // m, e_k above
  ErrorStatistics statistics;
};

// `matching` is CompareTrajectories(estimated, ground_truth)'s result.
AbsoluteErrors AbsolutePositionErrors(const std::vector<StampedPose2>& estimated,
                                      const std::vector<StampedPose2>& ground_truth,
                                      const TrajectoryErrors& matching);

struct RelativeErrors {
  double delta = 0.0;            // m of travelled ground-truth distance
  ErrorStatistics translation;   // m
  ErrorStatistics rotation;      // rad
};

RelativeErrors RelativePoseErrors(const std::vector<StampedPose2>& estimated,
                                  const std::vector<StampedPose2>& ground_truth,
                                  const TrajectoryErrors& matching, double delta);

}  // namespace graphslam::tools
