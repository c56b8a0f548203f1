// WorstOdometryChi2: the worst single odometry or motion step touching the
// marked poses, equal to the solver's own chi2 of that constraint
// (core::PoseFactorsChi2 of a problem holding it alone), and blind to the
// constraints that touch no marked pose.
#include "partition/initialization/internal/broken_odometry.h"

#include <gtest/gtest.h>

#include <vector>

#include "core/pose_factors.h"

namespace graphslam::partition::internal {
namespace {

// Three poses on a line, the third one folded (turned and shifted) against
// the two steps that lead to it.
core::Problem2d FoldedTrajectory() {
  core::Problem2d problem;
  problem.poses = {core::Pose2(0.0, 0.0, 0.0), core::Pose2(1.0, 0.0, 0.0),
                   core::Pose2(1.7, 0.4, 2.9)};
  core::RelativePoseConstraint step;
  step.from = 0;
  step.to = 1;
  step.z = core::Pose2(1.0, 0.05, 0.01);
  step.information = Eigen::Vector3d(4.0, 9.0, 25.0).asDiagonal();
  problem.relative_poses.push_back(step);
  core::VelocityMotionConstraint motion;
  motion.from = 1;
  motion.to = 2;
  motion.control = {1.0, 0.1, 1.0};
  motion.information = Eigen::Vector3d(100.0, 100.0, 400.0).asDiagonal();
  problem.motions.push_back(motion);
  return problem;
}

// The solver's chi2 of the problem's poses with only constraint `keep` of
// the two (0: the relative pose, 1: the motion).
double AloneChi2(const core::Problem2d& problem, int keep) {
  core::Problem2d alone = problem;
  if (keep == 0) alone.motions.clear();
  if (keep == 1) alone.relative_poses.clear();
  return core::PoseFactorsChi2(alone, alone.poses);
}

TEST(BrokenOdometry, WorstStepIsTheSolversChi2OfThatConstraint) {
  const core::Problem2d problem = FoldedTrajectory();
  const double step = AloneChi2(problem, 0);
  const double motion = AloneChi2(problem, 1);
  ASSERT_GT(step, 0.0);
  ASSERT_GT(motion, 100.0 * step) << "the fold is the motion step";
  EXPECT_NEAR(WorstOdometryChi2(problem, {1, 1, 1}), motion, 1e-9 * motion);
  // Marking only pose 0 sees the first step alone; pose 2 the motion.
  EXPECT_NEAR(WorstOdometryChi2(problem, {1, 0, 0}), step, 1e-12 + 1e-9 * step);
  EXPECT_NEAR(WorstOdometryChi2(problem, {0, 0, 1}), motion, 1e-9 * motion);
  EXPECT_EQ(WorstOdometryChi2(problem, {0, 0, 0}), 0.0);
}

TEST(BrokenOdometry, StepsThatFitGiveZero) {
  core::Problem2d problem = FoldedTrajectory();
  problem.motions.clear();
  problem.relative_poses[0].z = core::Pose2(1.0, 0.0, 0.0);
  EXPECT_NEAR(WorstOdometryChi2(problem, {1, 1, 1}), 0.0, 1e-20);
}

}  // namespace
}  // namespace graphslam::partition::internal
