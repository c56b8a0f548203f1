#include "core/gps_model.h"

#include <gtest/gtest.h>

#include <numbers>
#include <random>

#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;

TEST(GpsModel, ResidualIsPositionMinusFix) {
  Eigen::Vector2d residual;
  Eigen::Matrix<double, 2, 3> jacobian;
  EvaluateGps(Pose2(3.0, -4.0, 2.5), Eigen::Vector2d(1.0, 1.0), &residual, &jacobian);
  EXPECT_EQ(residual, Eigen::Vector2d(2.0, -5.0));
  Eigen::Matrix<double, 2, 3> expected;
  expected << 1, 0, 0, 0, 1, 0;
  EXPECT_EQ(jacobian, expected);
}

TEST(GpsModel, JacobianMatchesCentralDifferences) {
  std::mt19937 rng(20240615);
  std::uniform_real_distribution<double> position(-100.0, 100.0), angle(-3.14, 3.14);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 pose(position(rng), position(rng), angle(rng));
    const Eigen::Vector2d z(position(rng), position(rng));
    Eigen::Matrix<double, 2, 3> jacobian;
    EvaluateGps(pose, z, nullptr, &jacobian);
    const auto of_pose = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector2d e;
      EvaluateGps(x, z, &e, nullptr);
      return e;
    };
    const Eigen::MatrixXd numeric = NumericJacobian(of_pose, pose);
    EXPECT_LE((Eigen::MatrixXd(jacobian) - numeric).cwiseAbs().maxCoeff(), 1e-7)
        << "analytic:\n"
        << jacobian << "\nnumeric:\n"
        << numeric;
  }
}

}  // namespace
}  // namespace graphslam::core
