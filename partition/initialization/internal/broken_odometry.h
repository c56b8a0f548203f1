// The odometry a solved stage breaks: the largest chi2 e^T W e of one
// relative-pose or velocity-motion constraint of a problem at its poses
// (e as the solver evaluates it: core/relative_pose_model.h in increment
// form, core/velocity_motion_model.h), over the constraints that touch a
// pose marked in `touched`.
//
// A stage of incremental initialization can settle into a local minimum in
// which a stretch of its new poses is folded over (turned by up to pi and
// metres away) while the features that stretch saw moved with it: every
// observation fits, and the only witness is the few odometry steps at the
// fold's ends, each off by radians, i.e. a chi2 of thousands against the
// ~3 of a step that fits. The stage's total chi2 hides them among its
// observations, and the full solve afterwards does not undo such a fold
// (the folded stretch is its own basin), so the stage test looks at the
// single worst step (incremental_initialization.h: broken_odometry_chi2).
//
// THREAD SAFETY: pure function. ALLOCATION: none.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/problem.h"
#include "core/relative_pose_model.h"
#include "core/velocity_motion_model.h"

namespace graphslam::partition::internal {

// e^T W e of one relative-pose or velocity-motion constraint at `poses`.
inline double OdometryStepChi2(const core::RelativePoseConstraint& c,
                               const std::vector<core::Pose2>& poses) {
  Eigen::Vector3d e;
  core::EvaluateRelativePoseIncrement(poses[c.from], poses[c.to], c.z, &e, nullptr, nullptr);
  return e.dot(c.information * e);
}
inline double OdometryStepChi2(const core::VelocityMotionConstraint& c,
                               const std::vector<core::Pose2>& poses) {
  Eigen::Vector3d e;
  core::EvaluateVelocityMotion(poses[c.from], poses[c.to], c.control, &e, nullptr, nullptr);
  return e.dot(c.information * e);
}

// max of e^T W e at problem.poses over the odometry and motion constraints
// with an end pose p where touched[p] != 0 (touched: one entry per pose);
// 0 without any.
inline double WorstOdometryChi2(const core::Problem2d& problem,
                                const std::vector<uint8_t>& touched) {
  double worst = 0.0;
  for (const core::RelativePoseConstraint& c : problem.relative_poses)
    if (touched[c.from] || touched[c.to])
      worst = std::max(worst, OdometryStepChi2(c, problem.poses));
  for (const core::VelocityMotionConstraint& c : problem.motions)
    if (touched[c.from] || touched[c.to])
      worst = std::max(worst, OdometryStepChi2(c, problem.poses));
  return worst;
}

// An odometry step between consecutive poses, by its lower pose.
struct BrokenStep {
  int32_t pose = 0;  // min(from, to); the step joins pose and pose + 1
  double chi2 = 0.0;
};

// The relative-pose and motion constraints between consecutive poses
// (|to - from| = 1: odometry, not a loop closure) whose e^T W e at `poses`
// exceeds `bound`, ascending by pose.
inline std::vector<BrokenStep> BrokenOdometrySteps(const core::Problem2d& problem,
                                                   const std::vector<core::Pose2>& poses,
                                                   double bound) {
  std::vector<BrokenStep> steps;
  auto consider = [&](const auto& c) {
    if (c.to - c.from != 1 && c.from - c.to != 1) return;
    const double chi2 = OdometryStepChi2(c, poses);
    if (chi2 > bound) steps.push_back({std::min(c.from, c.to), chi2});
  };
  for (const core::RelativePoseConstraint& c : problem.relative_poses) consider(c);
  for (const core::VelocityMotionConstraint& c : problem.motions) consider(c);
  std::sort(steps.begin(), steps.end(),
            [](const BrokenStep& a, const BrokenStep& b) { return a.pose < b.pose; });
  return steps;
}

}  // namespace graphslam::partition::internal
