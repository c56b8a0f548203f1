#include "core/pose_range_bearing_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;
constexpr double kPi = std::numbers::pi;

double MaxAbs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

TEST(PoseRangeBearingModel, KnownRangeAndBearingIgnoreTheObservedHeading) {
  // Observer at (1, 1) facing +y; observed robot at (4, 5): range 5, bearing
  // atan2(4, 3) - pi/2, whatever the observed robot's heading.
  const Pose2 observer(1.0, 1.0, kPi / 2.0);
  for (double heading : {0.0, 1.0, -3.0}) {
    Eigen::Vector2d residual;
    ASSERT_TRUE(EvaluatePoseRangeBearing(observer, Pose2(4.0, 5.0, heading),
                                         Eigen::Vector2d(4.5, 0.1), &residual, nullptr, nullptr));
    EXPECT_NEAR(residual(0), 0.5, 1e-15);
    EXPECT_NEAR(residual(1), std::atan2(4.0, 3.0) - kPi / 2.0 - 0.1, 1e-15);
  }
  Eigen::Vector2d untouched(7.0, 7.0);
  EXPECT_FALSE(EvaluatePoseRangeBearing(observer, Pose2(1.0, 1.0, 0.3), Eigen::Vector2d(1.0, 0.0),
                                        &untouched, nullptr, nullptr));
  EXPECT_EQ(untouched, Eigen::Vector2d(7.0, 7.0));
}

// Both 2x3 Jacobians against central differences of the residual over the six
// pose coordinates, at random configurations, including bearings across +-pi
// (the residual is wrapped, so the differences stay small there too).
TEST(PoseRangeBearingModel, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(20261127);
  std::uniform_real_distribution<double> position(-10.0, 10.0), angle(-kPi, kPi);
  int large_residuals = 0;
  for (int trial = 0; trial < 200; ++trial) {
    Eigen::Matrix<double, 6, 1> x;
    x << position(rng), position(rng), angle(rng), position(rng), position(rng), angle(rng);
    if ((x.segment<2>(3) - x.head<2>()).norm() < 0.5) continue;
    const Eigen::Vector2d z(std::abs(position(rng)), angle(rng));
    const auto residual = [&z](const Eigen::VectorXd& v) -> Eigen::VectorXd {
      Eigen::Vector2d e;
      EXPECT_TRUE(EvaluatePoseRangeBearing(v.head<3>(), v.tail<3>(), z, &e, nullptr, nullptr));
      return e;
    };
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 3> ja, jb;
    ASSERT_TRUE(EvaluatePoseRangeBearing(x.head<3>(), x.tail<3>(), z, &e, &ja, &jb));
    if (std::abs(std::abs(e(1)) - kPi) < 1e-3) continue;  // the wrap itself is not smooth
    if (std::abs(e(1)) > kPi / 2) ++large_residuals;
    const Eigen::MatrixXd numeric = NumericJacobian(residual, x);
    EXPECT_LT(MaxAbs(numeric.leftCols(3) - ja), 1e-6) << "trial " << trial << "\n" << numeric;
    EXPECT_LT(MaxAbs(numeric.rightCols(3) - jb), 1e-6) << "trial " << trial << "\n" << numeric;
    EXPECT_EQ(jb(0, 2), 0.0);
    EXPECT_EQ(jb(1, 2), 0.0);
  }
  EXPECT_GT(large_residuals, 10);  // the draws reached bearing residuals the wrap folds
}

}  // namespace
}  // namespace graphslam::core
