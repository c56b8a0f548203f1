// AlignOdometryToGps (partition/initialization/gps_segment_alignment.h) against ground truth:
// a curving trajectory whose dead reckoning has a heading bias (so it drifts
// far from the truth) lands on the truth, up to the fixes' own error, and the
// odometry inside every segment stays exact; chains it must not touch stay
// bit for bit.
#include "partition/initialization/gps_segment_alignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "core/se2.h"

namespace graphslam::partition {
namespace {

using core::Pose2;

// Truth: a lawnmower-ish curve of `n` poses, 1 m steps, heading changing
// slowly. Odometry edges i -> i+1 measured with a 0.02 rad heading bias, so
// the dead reckoning turns away from the truth (hundreds of metres after 300
// poses). GPS every `gps_every` poses, offset by a known small error.
struct Scenario {
  core::Problem2d problem;
  std::vector<Pose2> truth;
};

Scenario MakeScenario(int n, int gps_every, double gps_error) {
  Scenario s;
  Pose2 x(10.0, -5.0, 0.3);
  for (int i = 0; i < n; ++i) {
    s.truth.push_back(x);
    const Pose2 step(1.0, 0.0, 0.05 * std::sin(0.02 * i));
    x = core::Compose(x, step);
    x.z() = core::WrapAngle(x.z());
  }
  Pose2 guess = s.truth[0];
  for (int i = 0; i < n; ++i) {
    s.problem.AddPose(i, guess, true, i + 1);
    if (i + 1 < n) {
      core::RelativePoseConstraint c;
      c.from = i;
      c.to = i + 1;
      c.z = core::Between(s.truth[i], s.truth[i + 1]);
      c.z.z() += 0.02;  // heading bias of the odometry
      c.information = Eigen::Matrix3d::Identity();
      s.problem.relative_poses.push_back(c);
      guess = core::Compose(guess, c.z);
    }
  }
  for (int i = 0; i < n; i += gps_every) {
    core::GpsConstraint g;
    g.pose = i;
    // Alternating offsets of size gps_error.
    g.z = s.truth[i].head<2>() + gps_error * Eigen::Vector2d((i / gps_every) % 2 ? 1 : -1, 0);
    s.problem.gps.push_back(g);
  }
  return s;
}

// Over poses [0, end) (end < 0: all).
double MaxPositionError(const core::Problem2d& problem, const std::vector<Pose2>& truth,
                        int end = -1) {
  double worst = 0.0;
  for (int i = 0; i < (end < 0 ? problem.num_poses() : end); ++i)
    worst = std::max(worst, (problem.poses[i].head<2>() - truth[i].head<2>()).norm());
  return worst;
}

TEST(GpsSegmentAlignment, DriftingDeadReckoningLandsOnTheTruth) {
  Scenario s = MakeScenario(300, 25, 0.0);
  ASSERT_GT(MaxPositionError(s.problem, s.truth), 100.0) << "the dead reckoning should drift";
  const GpsAlignmentSummary summary = AlignOdometryToGps(&s.problem);
  EXPECT_EQ(summary.chains, 1);
  EXPECT_EQ(summary.segments, 11);  // fixes at 0, 25, ..., 275
  EXPECT_EQ(summary.poses_moved, 300);
  // Exact fixes: inside a segment the error is the sagitta of the bias' arc
  // over its 25-step chord, 25^2 * 0.02 / 8 = 1.6 m; after the last fix (275)
  // the chord's heading (0.25 rad off the tangent) and the bias act for 24
  // more steps: ~12 m, still far below the drift.
  EXPECT_LT(MaxPositionError(s.problem, s.truth, 275), 2.0);
  EXPECT_LT(MaxPositionError(s.problem, s.truth), 15.0);
  // Every fix but the last (which follows the pair before it) holds its pose.
  for (const core::GpsConstraint& g : s.problem.gps) {
    if (g.pose == 275) continue;
    EXPECT_LT((s.problem.poses[g.pose].head<2>() - g.z).norm(), 1e-9) << "pose " << g.pose;
  }
  // Odometry inside a segment is still exact (a rigid motion per segment).
  for (const core::RelativePoseConstraint& c : s.problem.relative_poses) {
    if (c.to % 25 == 0) continue;  // the edge across a segment boundary
    const Pose2 between = core::Between(s.problem.poses[c.from], s.problem.poses[c.to]);
    EXPECT_NEAR(between.x(), c.z.x(), 1e-9);
    EXPECT_NEAR(between.y(), c.z.y(), 1e-9);
    EXPECT_NEAR(core::WrapAngle(between.z() - c.z.z()), 0.0, 1e-9);
  }
}

TEST(GpsSegmentAlignment, UnbiasedOdometryStaysWithinTheFixError) {
  Scenario s = MakeScenario(200, 20, 0.5);
  for (core::RelativePoseConstraint& c : s.problem.relative_poses) c.z.z() -= 0.02;  // no bias
  Pose2 guess = s.truth[0] + Pose2(30.0, 40.0, 1.0);  // dead reckoning from a wrong start
  for (int i = 0; i < 200; ++i) {
    s.problem.poses[i] = guess;
    if (i + 1 < 200) guess = core::Compose(guess, s.problem.relative_poses[i].z);
  }
  AlignOdometryToGps(&s.problem);
  // Each segment is the truth turned by at most ~2 * 0.5 m / 20 m and shifted
  // by 0.5 m: a couple of metres at most.
  EXPECT_LT(MaxPositionError(s.problem, s.truth), 2.0);
}

TEST(GpsSegmentAlignment, ChainsWithoutTwoFixesOrWithAFixedPoseStayUntouched) {
  Scenario s = MakeScenario(100, 40, 0.0);
  // Break the chain between 59 and 60: chain [0, 59] has fixes 0, 40; chain
  // [60, 99] has the fix 80 only.
  s.problem.relative_poses.erase(s.problem.relative_poses.begin() + 59);
  const std::vector<Pose2> before = s.problem.poses;
  GpsAlignmentSummary summary = AlignOdometryToGps(&s.problem);
  EXPECT_EQ(summary.chains, 1);
  EXPECT_EQ(summary.poses_moved, 60);
  for (int i = 60; i < 100; ++i) EXPECT_EQ(s.problem.poses[i], before[i]) << "pose " << i;

  // A fixed pose in the first chain: the caller's gauge, nothing moves.
  s.problem.poses = before;
  s.problem.pose_fixed[0] = 1;
  summary = AlignOdometryToGps(&s.problem);
  EXPECT_EQ(summary.chains, 0);
  for (int i = 0; i < 100; ++i) EXPECT_EQ(s.problem.poses[i], before[i]) << "pose " << i;
}

TEST(GpsSegmentAlignment, ShortPairsBorrowTheNeighbouringCorrection) {
  Scenario s = MakeScenario(200, 25, 0.0);
  // A second fix right after pose 100 would make a 1 m pair: moved onto
  // pose 101 with its own GPS so that 100 -> 101 is below 2 m.
  core::GpsConstraint extra;
  extra.pose = 101;
  extra.z = s.truth[101].head<2>();
  s.problem.gps.push_back(extra);
  const GpsAlignmentSummary summary = AlignOdometryToGps(&s.problem, 2.0);
  // 9 fixes (0..200 step 25: 8) + 101 = 9 fixes, 8 pairs; 100 -> 101 is short.
  EXPECT_EQ(summary.segments, 7);
  // Pair (100, 101) takes (75, 100)'s correction: poses 100..124 start from
  // pose 75's fix, an arc of 50 steps (sagitta 50^2 * 0.02 / 8 = 6.3 m at most).
  EXPECT_LT(MaxPositionError(s.problem, s.truth, 175), 7.0);
  EXPECT_LT((s.problem.poses[125].head<2>() - s.truth[125].head<2>()).norm(), 1e-9);
}

}  // namespace
}  // namespace graphslam::partition
