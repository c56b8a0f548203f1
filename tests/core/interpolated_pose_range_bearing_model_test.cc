// The robot-to-robot range-bearing constraint with the observed robot's
// position interpolated between two of its poses
// (core/interpolated_pose_range_bearing_model.h): alpha = 0 and 1 against the
// two-pose model bit for bit, the Jacobians against central differences at
// several alpha, and a solve where the observed robot has a pose only at
// every other sighting. (The three-pose factor's H and g against numeric
// differentiation of the cost: tests/core/pose_factors_test.cc,
// RobotSightingMatchesNumericDifferentiation.)
#include "core/interpolated_pose_range_bearing_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "core/angle.h"
#include "core/graphslam_solver.h"
#include "core/pose_factors.h"
#include "core/pose_range_bearing_model.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

using Jacobian23 = Eigen::Matrix<double, 2, 3>;

TEST(InterpolatedPoseRangeBearingModel, AlphaZeroAndOneAreTheTwoPoseModelBitForBit) {
  const Pose2 a(0.3, -1.2, 0.7), b0(2.9, 1.1, -2.0), b1(3.4, 0.2, 2.5);
  const Eigen::Vector2d z(3.1, 0.4);
  for (const double alpha : {0.0, 1.0}) {
    const Pose2& b = alpha == 0.0 ? b0 : b1;
    Eigen::Vector2d e, e_two;
    Jacobian23 ja, j0, j1, ja_two, jb_two;
    ASSERT_TRUE(EvaluateInterpolatedPoseRangeBearing(a, b0, b1, alpha, z, &e, &ja, &j0, &j1));
    ASSERT_TRUE(EvaluatePoseRangeBearing(a, b, z, &e_two, &ja_two, &jb_two));
    EXPECT_EQ(e, e_two) << alpha;
    EXPECT_EQ(ja, ja_two) << alpha;
    EXPECT_EQ(alpha == 0.0 ? j0 : j1, jb_two) << alpha;
    EXPECT_EQ(alpha == 0.0 ? j1 : j0, Jacobian23::Zero()) << alpha;
  }
}

TEST(InterpolatedPoseRangeBearingModel, ResidualAtTheMidpointAndAcrossPi) {
  // b moves from (2, 1) to (2, -1): at alpha = 0.5 it is at (2, 0), straight
  // ahead of a at range 2.
  const Pose2 a(0.0, 0.0, 0.0), b0(2.0, 1.0, 0.3), b1(2.0, -1.0, -0.3);
  Eigen::Vector2d e;
  ASSERT_TRUE(EvaluateInterpolatedPoseRangeBearing(a, b0, b1, 0.5, Eigen::Vector2d(2.0, 0.0), &e,
                                                   nullptr, nullptr, nullptr));
  EXPECT_NEAR(e.norm(), 0.0, 1e-15);
  // Behind the observer, a bearing of pi - 0.01 against a reading of
  // -pi + 0.01: the residual is wrapped to -0.02, not 2 pi - 0.02.
  const Pose2 c0(-2.0, 0.02, 0.0), c1(-2.0, 0.02, 1.0);
  const double bearing = std::atan2(0.02, -2.0);
  ASSERT_TRUE(EvaluateInterpolatedPoseRangeBearing(
      a, c0, c1, 0.4, Eigen::Vector2d(std::hypot(2.0, 0.02), -bearing), &e, nullptr, nullptr,
      nullptr));
  EXPECT_NEAR(e[0], 0.0, 1e-15);
  EXPECT_NEAR(e[1], WrapAngle(2.0 * bearing), 1e-12);
  EXPECT_LT(std::abs(e[1]), 0.03);
  // Coincident positions: no bearing, nothing returned.
  EXPECT_FALSE(EvaluateInterpolatedPoseRangeBearing(a, Pose2(-1.0, 0.0, 0.0), Pose2(1.0, 0.0, 0.0),
                                                    0.5, Eigen::Vector2d(1.0, 0.0), &e, nullptr,
                                                    nullptr, nullptr));
}

TEST(InterpolatedPoseRangeBearingModel, JacobiansMatchCentralDifferences) {
  std::mt19937_64 engine(21);
  std::uniform_real_distribution<double> coordinate(-5.0, 5.0), angle(-3.1, 3.1);
  for (const double alpha : {0.0, 0.25, 0.5, 0.8, 1.0}) {
    for (int draw = 0; draw < 20; ++draw) {
      Eigen::Matrix<double, 9, 1> x;
      for (int p = 0; p < 3; ++p)
        x.segment<3>(3 * p) << coordinate(engine), coordinate(engine), angle(engine);
      const Eigen::Vector2d z(3.0, angle(engine));
      const auto residual = [&](const Eigen::VectorXd& v) {
        Eigen::Vector2d e;
        EXPECT_TRUE(EvaluateInterpolatedPoseRangeBearing(v.segment<3>(0), v.segment<3>(3),
                                                         v.segment<3>(6), alpha, z, &e, nullptr,
                                                         nullptr, nullptr));
        return Eigen::VectorXd(e);
      };
      Eigen::Vector2d e;
      Jacobian23 ja, j0, j1;
      ASSERT_TRUE(EvaluateInterpolatedPoseRangeBearing(x.segment<3>(0), x.segment<3>(3),
                                                       x.segment<3>(6), alpha, z, &e, &ja, &j0,
                                                       &j1));
      const Eigen::MatrixXd numeric = testing::NumericJacobian(residual, x);
      EXPECT_LT((ja - numeric.middleCols<3>(0)).norm(), 1e-6) << alpha << " draw " << draw;
      EXPECT_LT((j0 - numeric.middleCols<3>(3)).norm(), 1e-6) << alpha << " draw " << draw;
      EXPECT_LT((j1 - numeric.middleCols<3>(6)).norm(), 1e-6) << alpha << " draw " << draw;
    }
  }
}

// Robot A (anchored at its first pose) drives a circle and reads robot B's
// range and bearing every 0.1 s, noise-free; B drives a straight line and has
// a pose only every 0.2 s, so every other sighting falls half-way between two
// of B's poses. B's odometry fixes its shape, only the sightings place it in
// A's frame. Interpolated, the solve puts B on its true path (chi2 ~ 0);
// snapped to B's pose before the stamp, the sightings are 0.1 m of B's motion
// off and the solve cannot fit them.
struct TwoRobots {
  Problem2d problem;
  std::vector<Pose2> truth;
  int32_t first_b = 0;
};

TwoRobots SparseObservedRobot(bool interpolate) {
  constexpr int kSteps = 40;
  constexpr double kDt = 0.1;
  TwoRobots out;
  Problem2d& problem = out.problem;
  std::vector<Pose2> a_truth, b_truth;
  for (int k = 0; k <= kSteps; ++k) {
    const double t = k * kDt;
    a_truth.emplace_back(3.0 * std::cos(0.2 * t), 3.0 * std::sin(0.2 * t),
                         WrapAngle(0.2 * t + M_PI / 2));
    if (k % 2 == 0) b_truth.emplace_back(-2.0 + 1.0 * t, 1.0 + 0.5 * t, std::atan2(0.5, 1.0));
  }
  // Initial guesses off the truth: A by a drift, B by a shift and a turn.
  for (size_t k = 0; k < a_truth.size(); ++k)
    problem.AddPose(static_cast<int64_t>(k),
                    k == 0 ? a_truth[0] : a_truth[k] + Pose2(0.01 * k, -0.02 * k, 0.01),
                    true, 0, k * kDt);
  problem.pose_fixed[0] = 1;
  out.first_b = problem.num_poses();
  for (size_t k = 0; k < b_truth.size(); ++k)
    problem.AddPose(static_cast<int64_t>(100 + k), b_truth[k] + Pose2(0.4, -0.3, 0.15), true, 0,
                    2 * k * kDt);
  out.truth = a_truth;
  out.truth.insert(out.truth.end(), b_truth.begin(), b_truth.end());
  const Eigen::Matrix3d odometry_information = Eigen::Vector3d(1e4, 1e4, 1e4).asDiagonal();
  const auto odometry = [&](int32_t from, int32_t to) {
    problem.relative_poses.push_back(
        {from, to, Between(out.truth[from], out.truth[to]), odometry_information, 0});
  };
  for (int32_t k = 0; k < kSteps; ++k) odometry(k, k + 1);
  for (int32_t k = 0; k + 1 < static_cast<int32_t>(b_truth.size()); ++k)
    odometry(out.first_b + k, out.first_b + k + 1);
  const Eigen::Matrix2d w = Eigen::Vector2d(1e4, 1e4).asDiagonal();
  for (int32_t k = 0; k <= kSteps; ++k) {
    // B's true position at t = k dt (B moves at constant velocity).
    const double t = k * kDt;
    const Eigen::Vector2d b(-2.0 + 1.0 * t, 1.0 + 0.5 * t);
    const Eigen::Vector2d d = b - a_truth[k].head<2>();
    PoseRangeBearingConstraint c;
    c.from = k;
    c.to = out.first_b + k / 2;
    c.z = Eigen::Vector2d(d.norm(), WrapAngle(std::atan2(d.y(), d.x()) - a_truth[k].z()));
    c.information = w;
    if (k % 2 == 1 && interpolate) {
      c.to_next = c.to + 1;
      c.alpha = 0.5;
    }
    problem.pose_range_bearings.push_back(c);
  }
  return out;
}

double MaxPositionError(const TwoRobots& robots, int32_t begin, int32_t end) {
  double worst = 0.0;
  for (int32_t p = begin; p < end; ++p)
    worst = std::max(worst, (robots.problem.poses[p].head<2>() - robots.truth[p].head<2>()).norm());
  return worst;
}

TEST(InterpolatedPoseRangeBearingModel, SolvePlacesARobotWithHalfAsManyPosesAsSightings) {
  for (const bool interpolate : {true, false}) {
    TwoRobots robots = SparseObservedRobot(interpolate);
    const int32_t num_poses = robots.problem.num_poses();
    ASSERT_EQ(num_poses - robots.first_b, 21);
    partition::InMemoryChunkSource chunks(robots.problem, partition::ChunkingOptions());
    SolverOptions options;
    options.max_iterations = 50;
    SolverSummary summary;
    const Status status = SolveGraphSlam(options, chunks, &robots.problem, &summary);
    ASSERT_TRUE(status.ok()) << status.ToString();
    const double b_error = MaxPositionError(robots, robots.first_b, num_poses);
    const double chi2 = PoseFactorsChi2(robots.problem, robots.problem.poses);
    // In the XML output (--gtest_output=xml): the figures docs/jobs.md quotes.
    ::testing::Test::RecordProperty(interpolate ? "interpolated_b_error_m" : "snapped_b_error_m",
                                    std::to_string(b_error));
    ::testing::Test::RecordProperty(interpolate ? "interpolated_chi2" : "snapped_chi2",
                                    std::to_string(chi2));
    if (interpolate) {
      // The truth is the optimum: B exactly on its path.
      EXPECT_TRUE(summary.converged) << summary.termination;
      EXPECT_LT(chi2, 1e-8);
      EXPECT_LT(b_error, 1e-5);
      EXPECT_LT(MaxPositionError(robots, 0, robots.first_b), 1e-5);
    } else {
      // B moves 0.1 m between a snapped sighting's stamp and its pose.
      EXPECT_GT(chi2, 10.0);
      EXPECT_GT(b_error, 0.01);
    }
  }
}

}  // namespace
}  // namespace graphslam::core
