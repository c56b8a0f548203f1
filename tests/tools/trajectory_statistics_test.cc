// ATE / RPE statistics against trajectories whose errors are worked out by
// hand.
#include "tools/trajectory_statistics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

namespace graphslam::tools {
namespace {

std::vector<StampedPose2> Line(int n, double spacing, double theta_step = 0.0) {
  std::vector<StampedPose2> poses;
  for (int i = 0; i < n; ++i) {
    StampedPose2 p;
    p.stamp = i;
    p.pose = core::Pose2(spacing * i, 0.0, theta_step * i);
    poses.push_back(p);
  }
  return poses;
}

TEST(Summarize, FourValues) {
  const ErrorStatistics s = Summarize({4.0, 1.0, 3.0, 2.0});
  EXPECT_EQ(s.count, 4);
  EXPECT_DOUBLE_EQ(s.mean, 2.5);
  EXPECT_DOUBLE_EQ(s.median, 2.5);                   // (2 + 3) / 2
  EXPECT_DOUBLE_EQ(s.rmse, std::sqrt(30.0 / 4.0));   // 1 + 4 + 9 + 16
  EXPECT_DOUBLE_EQ(s.std, std::sqrt(1.25));          // population
  EXPECT_DOUBLE_EQ(s.max, 4.0);
}

TEST(Summarize, OddCountAndEmpty) {
  EXPECT_DOUBLE_EQ(Summarize({5.0, 1.0, 2.0}).median, 2.0);
  const ErrorStatistics none = Summarize({});
  EXPECT_EQ(none.count, 0);
  EXPECT_TRUE(std::isnan(none.rmse));
  EXPECT_TRUE(std::isnan(none.median));
}

TEST(AbsolutePositionErrors, OffsetWithoutAlignmentIsTheOffset) {
  const std::vector<StampedPose2> truth = Line(11, 1.0);
  std::vector<StampedPose2> estimate = truth;
  for (size_t i = 0; i < estimate.size(); ++i) estimate[i].pose.y() = i % 2 == 0 ? 0.3 : -0.3;
  TrajectoryMatchOptions options;
  options.align = false;
  StatusOr<TrajectoryErrors> matching = CompareTrajectories(estimate, truth, options);
  ASSERT_TRUE(matching.ok()) << matching.status().ToString();
  const AbsoluteErrors ate = AbsolutePositionErrors(estimate, truth, *matching);
  ASSERT_EQ(ate.position.size(), 11u);
  EXPECT_DOUBLE_EQ(ate.stamps[3], 3.0);
  EXPECT_NEAR(ate.statistics.rmse, 0.3, 1e-12);
  EXPECT_NEAR(ate.statistics.mean, 0.3, 1e-12);
  EXPECT_NEAR(ate.statistics.std, 0.0, 1e-6);
  EXPECT_NEAR(ate.statistics.max, 0.3, 1e-12);
  EXPECT_NEAR(ate.statistics.rmse, matching->position_rmse, 1e-12);
}

TEST(AbsolutePositionErrors, AlignmentRemovesARigidMotion) {
  const std::vector<StampedPose2> truth = Line(20, 0.5);
  std::vector<StampedPose2> estimate = truth;
  const core::Pose2 motion(3.0, -2.0, 0.7);
  for (StampedPose2& p : estimate) p.pose = core::Compose(motion, p.pose);
  StatusOr<TrajectoryErrors> matching = CompareTrajectories(estimate, truth);
  ASSERT_TRUE(matching.ok());
  EXPECT_LT(AbsolutePositionErrors(estimate, truth, *matching).statistics.max, 1e-9);
}

// An odometry 10 % too long: every 1 m of true travel is 1.1 m estimated.
TEST(RelativePoseErrors, ScaleErrorGrowsWithTheDistance) {
  const std::vector<StampedPose2> truth = Line(21, 1.0);  // 20 m
  const std::vector<StampedPose2> estimate = Line(21, 1.1);
  StatusOr<TrajectoryErrors> matching = CompareTrajectories(estimate, truth);
  ASSERT_TRUE(matching.ok());
  const RelativeErrors one = RelativePoseErrors(estimate, truth, *matching, 1.0);
  EXPECT_EQ(one.translation.count, 20);  // pairs (i, i + 1)
  EXPECT_NEAR(one.translation.rmse, 0.1, 1e-9);
  EXPECT_NEAR(one.translation.max, 0.1, 1e-9);
  EXPECT_NEAR(one.rotation.max, 0.0, 1e-12);
  const RelativeErrors ten = RelativePoseErrors(estimate, truth, *matching, 10.0);
  EXPECT_EQ(ten.translation.count, 11);  // pairs (i, i + 10), i = 0..10
  EXPECT_NEAR(ten.translation.median, 1.0, 1e-9);
  // Longer than the path: no pair.
  EXPECT_EQ(RelativePoseErrors(estimate, truth, *matching, 25.0).translation.count, 0);
}

// A heading drift of 0.01 rad per pose: over 1 m (one step) 0.01 rad; the
// drifting frame also moves the next position sideways.
TEST(RelativePoseErrors, HeadingDrift) {
  const std::vector<StampedPose2> truth = Line(11, 1.0);
  std::vector<StampedPose2> estimate = truth;
  for (size_t i = 0; i < estimate.size(); ++i) estimate[i].pose.z() = 0.01 * static_cast<double>(i);
  TrajectoryMatchOptions options;
  options.align = false;
  StatusOr<TrajectoryErrors> matching = CompareTrajectories(estimate, truth, options);
  ASSERT_TRUE(matching.ok());
  const RelativeErrors one = RelativePoseErrors(estimate, truth, *matching, 1.0);
  EXPECT_EQ(one.rotation.count, 10);
  EXPECT_NEAR(one.rotation.mean, 0.01, 1e-12);
  // Estimated step in pose k's frame: R(-0.01 k) (1, 0); truth (1, 0).
  // |R(-a) (1, 0) - (1, 0)| = 2 sin(a / 2) for a = 0.01 k, k = 0..9.
  double max = 0;
  for (int k = 0; k < 10; ++k) max = std::max(max, 2 * std::sin(0.005 * k));
  EXPECT_NEAR(one.translation.max, max, 1e-12);
}

// Two runs one after another (stamps restart): no pair spans both.
TEST(RelativePoseErrors, PairsStayWithinARun) {
  std::vector<StampedPose2> truth = Line(6, 1.0);
  const std::vector<StampedPose2> second = Line(6, 1.0);
  truth.insert(truth.end(), second.begin(), second.end());
  StatusOr<TrajectoryErrors> matching = CompareTrajectories(truth, truth);
  ASSERT_TRUE(matching.ok()) << matching.status().ToString();
  EXPECT_EQ(RelativePoseErrors(truth, truth, *matching, 1.0).translation.count, 10);
  EXPECT_EQ(RelativePoseErrors(truth, truth, *matching, 5.0).translation.count, 2);
}

}  // namespace
}  // namespace graphslam::tools
