// SO(3)/SE(3) Exp/Log and the 3-D measurement models: round trips, series
// branches against the closed forms, and every analytic Jacobian against
// central differences through the solver's retraction x (+) d = x Exp(d).
#include <gtest/gtest.h>

#include <random>

#include "core/gps_3d_model.h"
#include "core/point_3d_observation_model.h"
#include "core/relative_pose_3d_model.h"
#include "core/se3_lie.h"
#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;

Pose3 RandomPose(std::mt19937& rng, double max_angle = 3.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  axis.normalize();
  std::uniform_real_distribution<double> angle(0.0, max_angle);
  Pose3 p;
  p.q = ExpSO3(angle(rng) * axis);
  p.t = Eigen::Vector3d(5 * u(rng), 5 * u(rng), 5 * u(rng));
  return p;
}

double RotationDistance(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return LogSO3(a.conjugate() * b).norm();
}

TEST(Se3Lie, ExpLogSo3RoundTripAcrossAngles) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (double angle : {0.0, 1e-12, 1e-8, 1e-5, 9.9e-5, 1.01e-4, 1e-3, 0.5, 2.0, 3.1, 3.14159}) {
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d phi = angle * Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
      const Eigen::Vector3d back = LogSO3(ExpSO3(phi));
      EXPECT_LT((back - phi).norm(), 1e-12 * std::max(1.0, angle)) << "angle " << angle;
      // The rotation matrix of Exp equals Eigen's angle-axis.
      if (angle > 0) {
        const Eigen::Matrix3d r = Eigen::AngleAxisd(phi.norm(), phi.normalized()).toRotationMatrix();
        EXPECT_LT((ExpSO3(phi).toRotationMatrix() - r).norm(), 1e-14);
      }
    }
  }
}

TEST(Se3Lie, LogOfNegatedQuaternionIsTheSame) {
  std::mt19937 rng(2);
  for (int k = 0; k < 50; ++k) {
    const Pose3 p = RandomPose(rng);
    Eigen::Quaterniond neg = p.q;
    neg.coeffs() = -neg.coeffs();
    EXPECT_LT((LogSO3(p.q) - LogSO3(neg)).norm(), 1e-12);
  }
}

TEST(Se3Lie, SeriesBranchesMatchClosedFormsAtTheirThresholds) {
  // Just below / above each switch the two branches must agree to ~1e-15.
  const Eigen::Vector3d axis = Eigen::Vector3d(1, -2, 0.5).normalized();
  for (double a : {0.0999, 0.1001, 1e-3, 1e-6, 1.0}) {
    const Eigen::Vector3d phi = a * axis;
    EXPECT_LT((LeftJacobianSO3(phi) * InverseLeftJacobianSO3(phi) - Eigen::Matrix3d::Identity())
                  .norm(),
              1e-14)
        << a;
    // V is continuous across the switch.
    EXPECT_LT((LeftJacobianSO3((0.1 - 1e-12) * axis) - LeftJacobianSO3((0.1 + 1e-12) * axis)).norm(),
              1e-11);
  }
  EXPECT_LT((ExpSO3(0.99999e-4 * axis).coeffs() - ExpSO3(1.00001e-4 * axis).coeffs()).norm(),
            1e-8);
}

TEST(Se3Lie, ExpLogSe3RoundTrip) {
  std::mt19937 rng(3);
  for (int k = 0; k < 200; ++k) {
    const Pose3 p = RandomPose(rng, k < 100 ? 3.1 : 1e-6);
    const Pose3 back = ExpSE3(LogSE3(p));
    EXPECT_LT((back.t - p.t).norm(), 1e-10);
    EXPECT_LT(RotationDistance(back.q, p.q), 1e-12);
  }
}

TEST(Se3Lie, LeftJacobianIsTheDerivativeOfTheTranslationPart) {
  // d/ds ExpSE3(s d).t at s -> ... : ExpSE3((rho, phi)).t = V(phi) rho, and
  // V(phi) = integral_0^1 Exp(s phi) ds: check against Simpson quadrature.
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-2.0, 2.0);
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d phi(u(rng), u(rng), u(rng));
    Eigen::Matrix3d integral = Eigen::Matrix3d::Zero();
    const int n = 2000;
    for (int i = 0; i <= n; ++i) {
      const double w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
      integral += w * ExpSO3(phi * (static_cast<double>(i) / n)).toRotationMatrix();
    }
    integral /= 3.0 * n;
    EXPECT_LT((integral - LeftJacobianSO3(phi)).norm(), 1e-10);
  }
}

TEST(Se3Lie, AdjointMovesAnIncrementAcrossAPose) {
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 0.3);
  for (int k = 0; k < 50; ++k) {
    const Pose3 t = RandomPose(rng);
    Vector6d d;
    for (int i = 0; i < 6; ++i) d[i] = n(rng);
    const Pose3 lhs = Compose(Compose(t, ExpSE3(d)), Inverse(t));
    const Pose3 rhs = ExpSE3(Adjoint(t) * d);
    EXPECT_LT((lhs.t - rhs.t).norm(), 1e-10);
    EXPECT_LT(RotationDistance(lhs.q, rhs.q), 1e-12);
  }
}

TEST(Se3Lie, RetractionMovesAPointAsItsJacobianSays) {
  // d/dd (x Exp(d)) p at 0 = [R | -R [p]x]
  std::mt19937 rng(6);
  const Pose3 x = RandomPose(rng);
  const Eigen::Vector3d p(0.3, -1.2, 2.0);
  auto f = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
    return TransformPoint(RetractPose3(x, d), p);
  };
  const Eigen::MatrixXd numeric = NumericJacobian(f, Eigen::VectorXd::Zero(6));
  Eigen::Matrix<double, 3, 6> analytic;
  analytic.leftCols<3>() = x.rotation();
  analytic.rightCols<3>() = -x.rotation() * Skew(p);
  EXPECT_LT((numeric - analytic).norm(), 1e-8);
}

// ---- EDGE_SE3:QUAT ----

TEST(RelativePose3Model, ZeroErrorWhenPosesAgreeWithTheMeasurement) {
  std::mt19937 rng(7);
  const Pose3 xi = RandomPose(rng), xj = RandomPose(rng);
  Vector6d e;
  EvaluateRelativePose3(xi, xj, Between(xi, xj), &e, nullptr, nullptr);
  EXPECT_LT(e.norm(), 1e-12);
}

TEST(RelativePose3Model, RotationErrorIsHalfTheRotationVectorToSecondOrder) {
  const Eigen::Vector3d phi(0.01, -0.02, 0.015);
  Pose3 xj;
  xj.q = ExpSO3(phi);
  Vector6d e;
  EvaluateRelativePose3(Pose3::Identity(), xj, Pose3::Identity(), &e, nullptr, nullptr);
  EXPECT_LT((e.tail<3>() - 0.5 * phi).norm(), phi.norm() * phi.squaredNorm());
}

TEST(RelativePose3Model, JacobiansMatchNumericDifferentiation) {
  std::mt19937 rng(8);
  for (int trial = 0; trial < 100; ++trial) {
    const Pose3 xi = RandomPose(rng), xj = RandomPose(rng);
    // Measurements near and far from the current relative pose.
    Pose3 z = trial % 2 ? Compose(Between(xi, xj), RandomPose(rng, 0.3)) : RandomPose(rng);
    Vector6d e;
    Matrix6d ji, jj;
    EvaluateRelativePose3(xi, xj, z, &e, &ji, &jj);
    auto fi = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      Vector6d out;
      EvaluateRelativePose3(RetractPose3(xi, d), xj, z, &out, nullptr, nullptr);
      return out;
    };
    auto fj = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      Vector6d out;
      EvaluateRelativePose3(xi, RetractPose3(xj, d), z, &out, nullptr, nullptr);
      return out;
    };
    const Eigen::MatrixXd ni = NumericJacobian(fi, Eigen::VectorXd::Zero(6));
    const Eigen::MatrixXd nj = NumericJacobian(fj, Eigen::VectorXd::Zero(6));
    EXPECT_LT((ni - ji).cwiseAbs().maxCoeff(), 1e-7 * (1.0 + ji.cwiseAbs().maxCoeff()))
        << "trial " << trial << "\n" << ni << "\n\n" << ji;
    EXPECT_LT((nj - jj).cwiseAbs().maxCoeff(), 1e-7 * (1.0 + jj.cwiseAbs().maxCoeff()))
        << "trial " << trial;
  }
}

TEST(RelativePose3Model, JacobianStaysCorrectWhereTheQuaternionSignFlips) {
  // Error rotation near pi: the canonical w >= 0 choice must not break J.
  const Pose3 xi = Pose3::Identity();
  Pose3 xj;
  xj.q = ExpSO3(Eigen::Vector3d(0, 0, 3.0));
  Matrix6d jj;
  EvaluateRelativePose3(xi, xj, Pose3::Identity(), nullptr, nullptr, &jj);
  auto f = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
    Vector6d out;
    EvaluateRelativePose3(xi, RetractPose3(xj, d), Pose3::Identity(), &out, nullptr, nullptr);
    return out;
  };
  EXPECT_LT((NumericJacobian(f, Eigen::VectorXd::Zero(6)) - jj).norm(), 1e-7);
}

// ---- point in the sensor frame, GPS ----

TEST(Point3ObservationModel, ResidualAndJacobiansMatchNumericDifferentiation) {
  std::mt19937 rng(9);
  for (int trial = 0; trial < 50; ++trial) {
    const Pose3 x = RandomPose(rng);
    const Point3 m(1.0 + trial * 0.1, -2.0, 0.5);
    const Eigen::Vector3d z(0.2, 0.1, -0.3);
    Eigen::Vector3d e;
    Eigen::Matrix<double, 3, 6> jp;
    Eigen::Matrix3d jm;
    EvaluatePoint3Observation(x, m, z, &e, &jp, &jm);
    EXPECT_LT((e - (x.rotation().transpose() * (m - x.t) - z)).norm(), 1e-12);
    auto fp = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      Eigen::Vector3d out;
      EvaluatePoint3Observation(RetractPose3(x, d), m, z, &out, nullptr, nullptr);
      return out;
    };
    auto fm = [&](const Eigen::VectorXd& dm) -> Eigen::VectorXd {
      Eigen::Vector3d out;
      EvaluatePoint3Observation(x, m + Eigen::Vector3d(dm), z, &out, nullptr, nullptr);
      return out;
    };
    EXPECT_LT((NumericJacobian(fp, Eigen::VectorXd::Zero(6)) - jp).norm(), 1e-7);
    EXPECT_LT((NumericJacobian(fm, Eigen::VectorXd::Zero(3)) - jm).norm(), 1e-8);
    // Inverting the observation puts the feature where it has zero error.
    const Point3 placed = InvertPoint3Observation(x, z);
    EvaluatePoint3Observation(x, placed, z, &e, nullptr, nullptr);
    EXPECT_LT(e.norm(), 1e-12);
  }
}

TEST(Gps3Model, ResidualAndJacobianMatchNumericDifferentiation) {
  std::mt19937 rng(10);
  for (int trial = 0; trial < 20; ++trial) {
    const Pose3 x = RandomPose(rng);
    const Eigen::Vector3d z(1.0, 2.0, 3.0);
    Eigen::Vector3d e;
    Eigen::Matrix<double, 3, 6> j;
    EvaluateGps3(x, z, &e, &j);
    EXPECT_LT((e - (x.t - z)).norm(), 1e-14);
    auto f = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
      Eigen::Vector3d out;
      EvaluateGps3(RetractPose3(x, d), z, &out, nullptr);
      return out;
    };
    EXPECT_LT((NumericJacobian(f, Eigen::VectorXd::Zero(6)) - j).norm(), 1e-8);
  }
}

}  // namespace
}  // namespace graphslam::core
