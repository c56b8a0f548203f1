#include "core/point_observation_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;
constexpr double kPi = std::numbers::pi;
constexpr unsigned kSeed = 20240614;

void ExpectNear(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double tolerance) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  const double error = (actual - expected).cwiseAbs().maxCoeff();
  EXPECT_LE(error, tolerance) << "actual:\n" << actual << "\nexpected:\n" << expected;
}

TEST(PointObservationModel, KnownPointInRobotFrame) {
  // Robot at (1, 1) facing +y: the world point (1, 3) is 2 m straight ahead.
  Eigen::Vector2d residual;
  EvaluatePointObservation(Pose2(1.0, 1.0, kPi / 2.0), Point2(1.0, 3.0), Eigen::Vector2d(2.0, 0.0),
                           &residual, nullptr, nullptr);
  ExpectNear(residual, Eigen::Vector2d::Zero(), 1e-15);
  // The world point (0, 1) is 1 m to the left: z = (0, 1); measured (0.5, 1.5).
  EvaluatePointObservation(Pose2(1.0, 1.0, kPi / 2.0), Point2(0.0, 1.0), Eigen::Vector2d(0.5, 1.5),
                           &residual, nullptr, nullptr);
  ExpectNear(residual, Eigen::Vector2d(-0.5, -0.5), 1e-15);
}

TEST(PointObservationModel, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> position(-20.0, 20.0), angle(-kPi, kPi);
  for (int i = 0; i < 1000; ++i) {
    Pose2 pose(position(rng), position(rng), angle(rng));
    if (i % 10 == 0) pose.z() = kPi - 1e-9;
    const Point2 feature(position(rng), position(rng));
    const Eigen::Vector2d z(position(rng), position(rng));
    SCOPED_TRACE(::testing::Message() << "draw " << i);
    Eigen::Vector2d residual;
    Eigen::Matrix<double, 2, 3> jacobian_pose;
    Eigen::Matrix2d jacobian_feature;
    EvaluatePointObservation(pose, feature, z, &residual, &jacobian_pose, &jacobian_feature);
    const auto of_pose = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector2d e;
      EvaluatePointObservation(x, feature, z, &e, nullptr, nullptr);
      return e;
    };
    const auto of_feature = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector2d e;
      EvaluatePointObservation(pose, x, z, &e, nullptr, nullptr);
      return e;
    };
    ExpectNear(jacobian_pose, NumericJacobian(of_pose, pose), 1e-7);
    ExpectNear(jacobian_feature, NumericJacobian(of_feature, feature), 1e-7);
  }
}

TEST(PointObservationModel, InvertPointObservationRoundTrips) {
  std::mt19937 rng(kSeed + 1);
  std::uniform_real_distribution<double> position(-50.0, 50.0), angle(-kPi, kPi);
  ExpectNear(InvertPointObservation(Pose2(1.0, 1.0, kPi / 2.0), Eigen::Vector2d(2.0, 0.0)),
             Point2(1.0, 3.0), 1e-15);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 pose(position(rng), position(rng), angle(rng));
    const Eigen::Vector2d z(position(rng), position(rng));
    Eigen::Vector2d residual;
    EvaluatePointObservation(pose, InvertPointObservation(pose, z), z, &residual, nullptr, nullptr);
    ExpectNear(residual, Eigen::Vector2d::Zero(), 1e-12);
  }
}

}  // namespace
}  // namespace graphslam::core
