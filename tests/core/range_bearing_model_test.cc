#include "core/range_bearing_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "tests/testing/numeric_diff.h"
#include "tests/testing/planar_draws.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;
constexpr double kPi = std::numbers::pi;
constexpr unsigned kSeed = 20240613;

void ExpectNear(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double tolerance) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  const double error = (actual - expected).cwiseAbs().maxCoeff();
  EXPECT_LE(error, tolerance) << "actual:\n" << actual << "\nexpected:\n" << expected;
}

TEST(RangeBearingModel, KnownRangeAndBearing) {
  // Robot at (1, 1) facing +y; feature at (4, 5): range 5, world angle
  // atan2(4, 3), bearing atan2(4, 3) - pi/2.
  const Pose2 pose(1.0, 1.0, kPi / 2.0);
  Eigen::Vector2d residual;
  ASSERT_TRUE(EvaluateRangeBearing(pose, Point2(4.0, 5.0), Eigen::Vector2d(0.0, 0.0), &residual,
                                   nullptr, nullptr));
  ExpectNear(residual, Eigen::Vector2d(5.0, std::atan2(4.0, 3.0) - kPi / 2.0), 1e-15);
  ASSERT_TRUE(EvaluateRangeBearing(pose, Point2(4.0, 5.0), Eigen::Vector2d(4.5, 0.1), &residual,
                                   nullptr, nullptr));
  ExpectNear(residual, Eigen::Vector2d(0.5, std::atan2(4.0, 3.0) - kPi / 2.0 - 0.1), 1e-15);
}

TEST(RangeBearingModel, BearingResidualIsWrappedForFeatureBehindRobotNearPi) {
  // Robot heading pi - 0.05; feature straight along world angle -pi + 0.05, so
  // the true bearing is +0.1 although atan2 - theta = -2 pi + 0.1.
  const Pose2 pose(1.0, 2.0, kPi - 0.05);
  const Point2 feature =
      pose.head<2>() + 3.0 * Eigen::Vector2d(std::cos(-kPi + 0.05), std::sin(-kPi + 0.05));
  Eigen::Vector2d residual;
  ASSERT_TRUE(
      EvaluateRangeBearing(pose, feature, Eigen::Vector2d(3.0, 0.1), &residual, nullptr, nullptr));
  ExpectNear(residual, Eigen::Vector2d::Zero(), 1e-12);
  ASSERT_TRUE(EvaluateRangeBearing(pose, feature, Eigen::Vector2d(3.0, 0.12 - 2.0 * kPi), &residual,
                                   nullptr, nullptr));
  ExpectNear(residual, Eigen::Vector2d(0.0, -0.02), 1e-12);
  // A feature behind the robot, measured at +pi - 0.01 while predicted at -pi + 0.01.
  const Pose2 origin(0.0, 0.0, 0.0);
  const Point2 behind(-2.0 * std::cos(0.01), -2.0 * std::sin(0.01));
  ASSERT_TRUE(EvaluateRangeBearing(origin, behind, Eigen::Vector2d(2.0, kPi - 0.01), &residual,
                                   nullptr, nullptr));
  ExpectNear(residual, Eigen::Vector2d(0.0, 0.02), 1e-12);
}

TEST(RangeBearingModel, JacobiansMatchCentralDifferencesIncludingAcrossPi) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> small(-0.05, 0.05);
  for (int i = 0; i < 1000; ++i) {
    const testing::PlanarDraw draw = testing::DrawAcrossPi(i, rng);
    const Pose2& pose = draw.pose;
    const Point2& feature = draw.feature;
    const double world_angle = draw.world_angle;
    // A measurement near the prediction, so the residual itself is small.
    const Eigen::Vector2d z = Eigen::Vector2d((feature - pose.head<2>()).norm() + small(rng),
                                              WrapAngle(world_angle - pose.z() + small(rng)));
    SCOPED_TRACE(::testing::Message() << "draw " << i << " pose " << pose.transpose() << " feature "
                                      << feature.transpose());
    Eigen::Vector2d residual;
    Eigen::Matrix<double, 2, 3> jacobian_pose;
    Eigen::Matrix2d jacobian_feature;
    ASSERT_TRUE(
        EvaluateRangeBearing(pose, feature, z, &residual, &jacobian_pose, &jacobian_feature));
    EXPECT_LE(residual.cwiseAbs().maxCoeff(), 0.1);
    const auto of_pose = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector2d e;
      EXPECT_TRUE(EvaluateRangeBearing(x, feature, z, &e, nullptr, nullptr));
      return e;
    };
    const auto of_feature = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector2d e;
      EXPECT_TRUE(EvaluateRangeBearing(pose, x, z, &e, nullptr, nullptr));
      return e;
    };
    // Central differences with h = 1e-6: truncation ~ h^2 / r^3, rounding ~ 1e-16 * 20 / h.
    ExpectNear(jacobian_pose, NumericJacobian(of_pose, pose), 1e-6);
    ExpectNear(jacobian_feature, NumericJacobian(of_feature, feature), 1e-6);
  }
}

TEST(RangeBearingModel, CoincidentFeatureIsRejectedAndOutputsUntouched) {
  const Pose2 pose(3.0, -1.0, 0.4);
  Eigen::Vector2d residual(7.0, 7.0);
  Eigen::Matrix<double, 2, 3> jacobian_pose = Eigen::Matrix<double, 2, 3>::Constant(7.0);
  Eigen::Matrix2d jacobian_feature = Eigen::Matrix2d::Constant(7.0);
  EXPECT_FALSE(EvaluateRangeBearing(pose, Point2(3.0, -1.0), Eigen::Vector2d(1.0, 0.0), &residual,
                                    &jacobian_pose, &jacobian_feature));
  EXPECT_FALSE(EvaluateRangeBearing(pose, Point2(3.0 + 1e-10, -1.0), Eigen::Vector2d(1.0, 0.0),
                                    &residual, &jacobian_pose, &jacobian_feature));
  ExpectNear(residual, Eigen::Vector2d(7.0, 7.0), 0.0);
  ExpectNear(jacobian_pose, Eigen::Matrix<double, 2, 3>::Constant(7.0), 0.0);
  ExpectNear(jacobian_feature, Eigen::Matrix2d::Constant(7.0), 0.0);
  // Just above the threshold (q = 1e-16 > 1e-18) it is evaluated.
  EXPECT_TRUE(EvaluateRangeBearing(pose, Point2(3.0, -1.0 + 1e-8), Eigen::Vector2d(0.0, 0.0),
                                   &residual, nullptr, nullptr));
}

TEST(RangeBearingModel, InvertRangeBearingRoundTrips) {
  std::mt19937 rng(kSeed + 1);
  std::uniform_real_distribution<double> position(-50.0, 50.0), angle(-kPi, kPi), range(0.1, 50.0);
  ExpectNear(InvertRangeBearing(Pose2(1.0, 1.0, kPi / 2.0), Eigen::Vector2d(2.0, kPi / 2.0)),
             Point2(-1.0, 1.0), 1e-15);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 pose(position(rng), position(rng), angle(rng));
    const Eigen::Vector2d z(range(rng), angle(rng));
    const Point2 feature = InvertRangeBearing(pose, z);
    Eigen::Vector2d residual;
    ASSERT_TRUE(EvaluateRangeBearing(pose, feature, z, &residual, nullptr, nullptr));
    ExpectNear(residual, Eigen::Vector2d::Zero(), 1e-11);
  }
}

}  // namespace
}  // namespace graphslam::core
