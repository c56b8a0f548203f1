#include "core/relative_pose_model.h"

#include <gtest/gtest.h>

#include <Eigen/LU>
#include <cmath>
#include <numbers>
#include <random>

#include "core/se2.h"
#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;
constexpr double kPi = std::numbers::pi;
constexpr unsigned kSeed = 20240612;

void ExpectNear(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double tolerance) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  const double error = (actual - expected).cwiseAbs().maxCoeff();
  EXPECT_LE(error, tolerance) << "actual:\n" << actual << "\nexpected:\n" << expected;
}

// Pose difference with the angle wrapped.
Eigen::Vector3d PoseError(const Pose2& a, const Pose2& b) {
  Eigen::Vector3d d = a - b;
  d.z() = WrapAngle(d.z());
  return d;
}

// g2o's v2t / t2v through 3x3 homogeneous matrices: an independent reference.
Eigen::Matrix3d V2t(const Pose2& p) {
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();
  t.block<2, 2>(0, 0) = Rotation2(p.z());
  t.block<2, 1>(0, 2) = p.head<2>();
  return t;
}
Pose2 T2v(const Eigen::Matrix3d& t) {
  return Pose2(t(0, 2), t(1, 2), std::atan2(t(1, 0), t(0, 0)));
}

Pose2 RandomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> position(-20.0, 20.0), angle(-kPi, kPi);
  return Pose2(position(rng), position(rng), angle(rng));
}

struct Edge {
  Pose2 from, to, z;
};

// Poses and a measurement near the truth, so the residual is away from its
// own wrap; draw i % 10 == 0 straddles +-pi in both headings.
Edge RandomEdge(std::mt19937& rng, int i) {
  std::normal_distribution<double> noise(0.0, 0.1);
  Edge edge{RandomPose(rng), RandomPose(rng), Pose2::Zero()};
  if (i % 10 == 0) {
    edge.from.z() = kPi - 1e-7;
    edge.to.z() = -kPi + 1e-7;
  }
  edge.z = Between(edge.from, edge.to) + Pose2(noise(rng), noise(rng), noise(rng));
  return edge;
}

TEST(Se2, ComposeBetweenAndInverseAreConsistent) {
  std::mt19937 rng(kSeed);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 a = RandomPose(rng), b = RandomPose(rng);
    ExpectNear(PoseError(Compose(a, Between(a, b)), b), Eigen::Vector3d::Zero(), 1e-12);
    ExpectNear(PoseError(Between(a, Compose(a, b)), b), Eigen::Vector3d::Zero(), 1e-12);
    ExpectNear(PoseError(Between(a, b), Compose(Inverse(a), b)), Eigen::Vector3d::Zero(), 1e-12);
    ExpectNear(PoseError(Compose(a, Inverse(a)), Pose2::Zero()), Eigen::Vector3d::Zero(), 1e-12);
    ExpectNear(PoseError(Inverse(Inverse(a)), a), Eigen::Vector3d::Zero(), 1e-12);
    ExpectNear(PoseError(Compose(a, b), T2v(V2t(a) * V2t(b))), Eigen::Vector3d::Zero(), 1e-12);
    EXPECT_GT(Compose(a, b).z(), -kPi);
    EXPECT_LE(Compose(a, b).z(), kPi);
  }
}

TEST(RelativePoseModel, ResidualMatchesG2oDefinition) {
  std::mt19937 rng(kSeed + 1);
  for (int i = 0; i < 1000; ++i) {
    const Pose2 from = RandomPose(rng), to = RandomPose(rng), z = RandomPose(rng);
    Eigen::Vector3d residual;
    EvaluateRelativePose(from, to, z, &residual, nullptr, nullptr);
    // e = t2v(Z^{-1} X_i^{-1} X_j)
    const Pose2 expected = T2v(V2t(z).inverse() * V2t(from).inverse() * V2t(to));
    ExpectNear(PoseError(residual, expected), Eigen::Vector3d::Zero(), 1e-10);
    EXPECT_GT(residual.z(), -kPi);
    EXPECT_LE(residual.z(), kPi);
  }
}

TEST(RelativePoseModel, ResidualIsZeroForExactMeasurementAndKnownOtherwise) {
  const Pose2 from(1.0, 2.0, kPi / 2.0), to(1.0, 5.0, kPi / 2.0);
  Eigen::Vector3d residual;
  EvaluateRelativePose(from, to, Pose2(3.0, 0.0, 0.0), &residual, nullptr, nullptr);
  ExpectNear(residual, Eigen::Vector3d::Zero(), 1e-15);
  // Measured 2.5 m ahead with a 0.1 rad turn: e = R(-0.1) (0.5, 0) and -0.1.
  EvaluateRelativePose(from, to, Pose2(2.5, 0.0, 0.1), &residual, nullptr, nullptr);
  ExpectNear(residual, Eigen::Vector3d(0.5 * std::cos(0.1), -0.5 * std::sin(0.1), -0.1), 1e-15);
}

TEST(RelativePoseModel, AngleResidualIsWrappedAcrossPi) {
  // from at +179.4 deg, to at -179.4 deg: the true turn is +0.02 rad... plus 2 pi.
  const Pose2 from(0.0, 0.0, kPi - 0.01), to(0.0, 0.0, -kPi + 0.01);
  Eigen::Vector3d residual;
  EvaluateRelativePose(from, to, Pose2(0.0, 0.0, 0.02), &residual, nullptr, nullptr);
  EXPECT_NEAR(residual.z(), 0.0, 1e-12);
  EvaluateRelativePose(from, to, Pose2(0.0, 0.0, -0.03), &residual, nullptr, nullptr);
  EXPECT_NEAR(residual.z(), 0.05, 1e-12);
  EvaluateRelativePose(from, to, Pose2(0.0, 0.0, 2.0 * kPi + 0.01), &residual, nullptr, nullptr);
  EXPECT_NEAR(residual.z(), 0.01, 1e-12);
}

TEST(RelativePoseModel, JacobiansMatchCentralDifferences) {
  std::mt19937 rng(kSeed + 2);
  for (int i = 0; i < 1000; ++i) {
    const auto [from, to, z] = RandomEdge(rng, i);
    SCOPED_TRACE(::testing::Message() << "from " << from.transpose() << " to " << to.transpose());
    Eigen::Matrix3d jacobian_from, jacobian_to;
    Eigen::Vector3d residual;
    EvaluateRelativePose(from, to, z, &residual, &jacobian_from, &jacobian_to);
    const auto of_from = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector3d e;
      EvaluateRelativePose(x, to, z, &e, nullptr, nullptr);
      return e;
    };
    const auto of_to = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector3d e;
      EvaluateRelativePose(from, x, z, &e, nullptr, nullptr);
      return e;
    };
    ExpectNear(jacobian_from, NumericJacobian(of_from, from), 1e-7);
    ExpectNear(jacobian_to, NumericJacobian(of_to, to), 1e-7);
    // Jacobians alone (null residual) agree with the full call.
    Eigen::Matrix3d only_from, only_to;
    EvaluateRelativePose(from, to, z, nullptr, &only_from, &only_to);
    ExpectNear(only_from, jacobian_from, 0.0);
    ExpectNear(only_to, jacobian_to, 0.0);
  }
}

TEST(RelativePoseModel, IncrementFormMatchesTheResidualAndCentralDifferencesOfTheRetraction) {
  std::mt19937 rng(kSeed + 3);
  for (int i = 0; i < 1000; ++i) {
    const auto [from, to, z] = RandomEdge(rng, i);
    SCOPED_TRACE(::testing::Message() << "from " << from.transpose() << " to " << to.transpose());
    Eigen::Vector3d residual, expected_residual;
    Eigen::Matrix3d jacobian_from, jacobian_to, xyt_from, xyt_to;
    EvaluateRelativePoseIncrement(from, to, z, &residual, &jacobian_from, &jacobian_to);
    EvaluateRelativePose(from, to, z, &expected_residual, &xyt_from, &xyt_to);
    // The same arithmetic for the residual: bit for bit.
    ExpectNear(residual, expected_residual, 0.0);
    // J_d = J_xytheta * RetractionJacobian.
    ExpectNear(jacobian_from, xyt_from * RetractionJacobian(from), 1e-12);
    ExpectNear(jacobian_to, xyt_to * RetractionJacobian(to), 1e-12);
    // And against central differences through the retraction x (+) d.
    const auto of_from = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      Eigen::Vector3d e;
      EvaluateRelativePoseIncrement(RetractPose(from, d), to, z, &e, nullptr, nullptr);
      return e;
    };
    const auto of_to = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      Eigen::Vector3d e;
      EvaluateRelativePoseIncrement(from, RetractPose(to, d), z, &e, nullptr, nullptr);
      return e;
    };
    ExpectNear(jacobian_from, NumericJacobian(of_from, Eigen::Vector3d::Zero()), 1e-7);
    ExpectNear(jacobian_to, NumericJacobian(of_to, Eigen::Vector3d::Zero()), 1e-7);
    Eigen::Matrix3d only_from, only_to;
    EvaluateRelativePoseIncrement(from, to, z, nullptr, &only_from, &only_to);
    ExpectNear(only_from, jacobian_from, 0.0);
    ExpectNear(only_to, jacobian_to, 0.0);
  }
}

}  // namespace
}  // namespace graphslam::core
