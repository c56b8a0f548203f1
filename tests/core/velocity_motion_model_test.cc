#include "core/velocity_motion_model.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "tests/testing/numeric_diff.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;
constexpr double kPi = std::numbers::pi;
constexpr unsigned kSeed = 20240611;

// Max-abs comparison that prints both matrices on failure.
void ExpectNear(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected, double tolerance) {
  ASSERT_EQ(actual.rows(), expected.rows());
  ASSERT_EQ(actual.cols(), expected.cols());
  const double error = (actual - expected).cwiseAbs().maxCoeff();
  EXPECT_LE(error, tolerance) << "actual:\n" << actual << "\nexpected:\n" << expected;
}

// The paper's closed form (Table 1 l.4), valid for omega != 0.
Pose2 PaperPrediction(const Pose2& p, const VelocityControl& u) {
  const double r = u.v / u.omega, th = p.z(), th2 = p.z() + u.omega * u.dt;
  return Pose2(p.x() - r * std::sin(th) + r * std::sin(th2),
               p.y() + r * std::cos(th) - r * std::cos(th2), WrapAngle(th2));
}

// Angular velocities that stress the omega -> 0 handling, then random ones.
double DrawOmega(int draw, std::mt19937& rng, double dt) {
  static const double kSpecial[] = {0.0, 1e-9, -1e-9, 1e-7, -1e-7, 1e-5, -1e-4};
  constexpr int kNumSpecial = sizeof(kSpecial) / sizeof(kSpecial[0]);
  if (draw % 4 == 0) return kSpecial[(draw / 4) % kNumSpecial];
  // Both sides of the series threshold |omega dt| = 1e-2.
  if (draw % 4 == 1) return std::uniform_real_distribution<double>(-2e-2, 2e-2)(rng) / dt;
  return std::uniform_real_distribution<double>(-3.0, 3.0)(rng);
}

struct Draw {
  Pose2 previous;
  VelocityControl control;
};

std::vector<Draw> RandomDraws(int count) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> position(-10.0, 10.0), angle(-kPi, kPi),
      velocity(-2.0, 2.0), duration(0.05, 2.0);
  std::vector<Draw> draws;
  for (int i = 0; i < count; ++i) {
    Draw d;
    d.previous = Pose2(position(rng), position(rng), angle(rng));
    d.control.v = velocity(rng);
    d.control.dt = duration(rng);
    d.control.omega = DrawOmega(i, rng, d.control.dt);
    draws.push_back(d);
  }
  return draws;
}

TEST(VelocityMotionModel, StraightLineWhenOmegaIsExactlyZero) {
  const Pose2 previous(1.0, -2.0, kPi / 6.0);
  const VelocityControl control{.v = 2.0, .omega = 0.0, .dt = 1.5};
  const Pose2 predicted = PredictVelocityMotion(previous, control);
  ExpectNear(predicted,
             Pose2(1.0 + 3.0 * std::cos(kPi / 6.0), -2.0 + 3.0 * std::sin(kPi / 6.0), kPi / 6.0),
             1e-15);
}

TEST(VelocityMotionModel, QuarterTurnEndsOnTheCircle) {
  // v = 1, omega = pi/2 for 1 s: a quarter of a circle of radius 2/pi, centred
  // at (0, 2/pi), counter-clockwise from the origin.
  const double radius = 2.0 / kPi;
  const VelocityControl control{.v = 1.0, .omega = kPi / 2.0, .dt = 1.0};
  ExpectNear(PredictVelocityMotion(Pose2::Zero(), control), Pose2(radius, radius, kPi / 2.0),
             1e-15);
  // Four quarter turns return to the start.
  Pose2 pose(3.0, 4.0, -2.0);
  for (int i = 0; i < 4; ++i) pose = PredictVelocityMotion(pose, control);
  ExpectNear(pose, Pose2(3.0, 4.0, -2.0), 1e-14);
}

TEST(VelocityMotionModel, MatchesPaperFormulaAwayFromZeroOmega) {
  for (const Draw& d : RandomDraws(1000)) {
    if (std::abs(d.control.omega * d.control.dt) < 1e-3) continue;
    SCOPED_TRACE(::testing::Message() << "omega " << d.control.omega << " dt " << d.control.dt);
    const Pose2 predicted = PredictVelocityMotion(d.previous, d.control);
    Eigen::Vector3d difference = predicted - PaperPrediction(d.previous, d.control);
    difference.z() = WrapAngle(difference.z());
    // The paper form loses ~eps * |v/omega| to cancellation.
    EXPECT_LE(difference.cwiseAbs().maxCoeff(), 1e-11) << difference.transpose();
  }
}

TEST(VelocityMotionModel, ValuesAndJacobiansAreContinuousThroughZeroOmega) {
  const Pose2 previous(0.5, 1.5, 2.0);
  const double dt = 0.5;
  const VelocityControl at_zero{.v = 1.3, .omega = 0.0, .dt = dt};
  const Pose2 straight = PredictVelocityMotion(previous, at_zero);
  for (double omega : {1e-12, -1e-9, 1e-9, 1e-7, -1e-7}) {
    SCOPED_TRACE(::testing::Message() << "omega " << omega);
    const VelocityControl tiny{.v = 1.3, .omega = omega, .dt = dt};
    // |g(omega) - g(0)| <= |dg/domega| |omega| with |dg/domega| <= v dt^2 / 2 + dt.
    ExpectNear(PredictVelocityMotion(previous, tiny), straight, 1.5 * std::abs(omega));
    ExpectNear(VelocityMotionJacobian(previous, tiny), VelocityMotionJacobian(previous, at_zero),
               1.5 * std::abs(omega));
    ExpectNear(VelocityControlJacobian(previous, tiny), VelocityControlJacobian(previous, at_zero),
               1.5 * std::abs(omega));
  }
  // Across the switch between series and closed form (|omega dt| = 1e-2).
  for (double sign : {1.0, -1.0}) {
    const VelocityControl below{.v = 1.3, .omega = sign * (1e-2 - 1e-15) / dt, .dt = dt};
    const VelocityControl above{.v = 1.3, .omega = sign * (1e-2 + 1e-15) / dt, .dt = dt};
    ExpectNear(PredictVelocityMotion(previous, below), PredictVelocityMotion(previous, above),
               1e-14);
    ExpectNear(VelocityMotionJacobian(previous, below), VelocityMotionJacobian(previous, above),
               1e-14);
    ExpectNear(VelocityControlJacobian(previous, below), VelocityControlJacobian(previous, above),
               1e-12);
  }
}

TEST(VelocityMotionModel, StateJacobianMatchesCentralDifferences) {
  for (const Draw& d : RandomDraws(1000)) {
    SCOPED_TRACE(::testing::Message()
                 << "previous " << d.previous.transpose() << " v " << d.control.v << " omega "
                 << d.control.omega << " dt " << d.control.dt);
    const Pose2 current = PredictVelocityMotion(d.previous, d.control) + Pose2(0.1, -0.2, 0.05);
    Eigen::Matrix3d jacobian_previous, jacobian_current;
    Eigen::Vector3d residual;
    EvaluateVelocityMotion(d.previous, current, d.control, &residual, &jacobian_previous,
                           &jacobian_current);
    ExpectNear(residual, Eigen::Vector3d(0.1, -0.2, 0.05), 1e-12);
    const auto residual_of_previous = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector3d e;
      EvaluateVelocityMotion(x, current, d.control, &e, nullptr, nullptr);
      return e;
    };
    const auto residual_of_current = [&](const Eigen::VectorXd& x) -> Eigen::VectorXd {
      Eigen::Vector3d e;
      EvaluateVelocityMotion(d.previous, x, d.control, &e, nullptr, nullptr);
      return e;
    };
    ExpectNear(jacobian_previous, NumericJacobian(residual_of_previous, d.previous), 1e-7);
    ExpectNear(jacobian_current, NumericJacobian(residual_of_current, current), 1e-7);
    ExpectNear(-jacobian_previous, VelocityMotionJacobian(d.previous, d.control), 0.0);
  }
}

TEST(VelocityMotionModel, ControlJacobianMatchesCentralDifferences) {
  for (const Draw& d : RandomDraws(1000)) {
    SCOPED_TRACE(::testing::Message()
                 << "v " << d.control.v << " omega " << d.control.omega << " dt " << d.control.dt);
    // g(v, omega, gamma): the final rotation gamma dt of Prob. Robotics Table 5.3.
    const auto prediction = [&](const Eigen::VectorXd& u) -> Eigen::VectorXd {
      VelocityControl control = d.control;
      control.v = u(0);
      control.omega = u(1);
      Pose2 out = PredictVelocityMotion(d.previous, control);
      out.z() = WrapAngle(out.z() - d.previous.z() + u(2) * control.dt);  // relative, no wrap jumps
      return out;
    };
    const Eigen::Vector3d u(d.control.v, d.control.omega, 0.0);
    ExpectNear(VelocityControlJacobian(d.previous, d.control), NumericJacobian(prediction, u),
               1e-7);
  }
}

TEST(VelocityMotionModel, ResidualAngleIsWrapped) {
  const VelocityControl control{.v = 0.0, .omega = 0.02, .dt = 1.0};
  const Pose2 previous(0.0, 0.0, kPi - 0.01);  // predicted theta = -pi + 0.01
  Eigen::Vector3d residual;
  EvaluateVelocityMotion(previous, Pose2(0.0, 0.0, kPi - 0.01), control, &residual, nullptr,
                         nullptr);
  EXPECT_NEAR(residual.z(), -0.02, 1e-12);
  EvaluateVelocityMotion(previous, Pose2(0.0, 0.0, -kPi + 0.03), control, &residual, nullptr,
                         nullptr);
  EXPECT_NEAR(residual.z(), 0.02, 1e-12);
  EXPECT_NEAR(PredictVelocityMotion(previous, control).z(), -kPi + 0.01, 1e-12);
}

TEST(VelocityMotionModel, InverseMotionUndoesPrediction) {
  for (const Draw& d : RandomDraws(1000)) {
    const Pose2 current = PredictVelocityMotion(d.previous, d.control);
    Eigen::Vector3d difference = InverseVelocityMotion(current, d.control) - d.previous;
    difference.z() = WrapAngle(difference.z());
    EXPECT_LE(difference.cwiseAbs().maxCoeff(), 1e-12) << difference.transpose();
  }
}

TEST(VelocityMotionModel, CovarianceIsVMVtransposePlusFloor) {
  VelocityNoise noise;
  noise.min_sigma_xy = 0.01;
  noise.min_sigma_theta = 0.002;
  const Eigen::Matrix3d floor = Eigen::Vector3d(1e-4, 1e-4, 4e-6).asDiagonal();
  // Standing still: only the floor remains.
  ExpectNear(
      VelocityMotionCovariance(Pose2(1, 2, 3), VelocityControl{.v = 0, .omega = 0, .dt = 1}, noise),
      floor, 0.0);
  for (const Draw& d : RandomDraws(200)) {
    const double v2 = d.control.v * d.control.v, w2 = d.control.omega * d.control.omega;
    const Eigen::Vector3d m(noise.alpha[0] * v2 + noise.alpha[1] * w2,
                            noise.alpha[2] * v2 + noise.alpha[3] * w2,
                            noise.alpha[4] * v2 + noise.alpha[5] * w2);
    const Eigen::Matrix3d v = VelocityControlJacobian(d.previous, d.control);
    const Eigen::Matrix3d covariance = VelocityMotionCovariance(d.previous, d.control, noise);
    ExpectNear(covariance, v * m.asDiagonal() * v.transpose() + floor, 1e-14);
    ExpectNear(covariance, covariance.transpose(), 0.0);
    EXPECT_EQ(Eigen::LLT<Eigen::Matrix3d>(covariance).info(), Eigen::Success);
  }
  // Straight drive (omega = 0, theta = 0): the along-track variance is
  // a1 v^2 dt^2 (+ floor); the heading variance is (a3 + a5) v^2 dt^2 (+ floor),
  // from omega and from the final rotation gamma.
  const VelocityControl straight{.v = 2.0, .omega = 0.0, .dt = 0.5};
  const Eigen::Matrix3d covariance = VelocityMotionCovariance(Pose2::Zero(), straight, noise);
  EXPECT_NEAR(covariance(0, 0), noise.alpha[0] * 4.0 * 0.25 + 1e-4, 1e-15);
  EXPECT_NEAR(covariance(2, 2), (noise.alpha[2] + noise.alpha[4]) * 4.0 * 0.25 + 4e-6, 1e-15);
}

// The covariance of the pose after `steps` equal steps that drive `control`
// for a total of `seconds`: Sigma_{k+1} = G Sigma_k G^T + R_k from Sigma_0 = 0.
Eigen::Matrix3d AccumulatedCovariance(VelocityControl control, double seconds, int steps,
                                      const VelocityNoise& noise) {
  control.dt = seconds / steps;
  Pose2 pose = Pose2::Zero();
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  for (int k = 0; k < steps; ++k) {
    const Eigen::Matrix3d g = VelocityMotionJacobian(pose, control);
    sigma = g * sigma * g.transpose() + VelocityMotionCovariance(pose, control, noise);
    pose = PredictVelocityMotion(pose, control);
  }
  return sigma;
}

// Largest relative difference of the diagonals (the variances of x, y, theta).
double RelativeDifference(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return ((a.diagonal() - b.diagonal()).array() / b.diagonal().array()).abs().maxCoeff();
}

TEST(VelocityMotionModel, RateIndependentNoiseAccumulatesTheSameAtAnyRate) {
  const VelocityControl control{.v = 0.4, .omega = 0.15, .dt = 0.0};
  const double seconds = 16.0;
  // A small floor, so that the per-step model's rate dependence below is the
  // alphas' (its floor's, growing with the rate, would partly offset it).
  VelocityNoise per_step;
  per_step.min_sigma_xy = per_step.min_sigma_theta = 1e-4;
  VelocityNoise per_time = per_step;
  per_time.noise_time_constant = 0.2;
  const Eigen::Matrix3d fine = AccumulatedCovariance(control, seconds, 5000, per_time);
  for (const int steps : {50, 500}) {
    EXPECT_LE(RelativeDifference(AccumulatedCovariance(control, seconds, steps, per_time), fine),
              0.03)
        << steps << " steps";
  }
  // The per-step model at the same three rates: the variances fall with the
  // rate, far beyond a few percent.
  const Eigen::Matrix3d per_step_fine = AccumulatedCovariance(control, seconds, 5000, per_step);
  for (const int steps : {50, 500}) {
    EXPECT_GE(RelativeDifference(AccumulatedCovariance(control, seconds, steps, per_step),
                                 per_step_fine),
              0.5)
        << steps << " steps";
  }
  // At dt = tau each step is the per-step model's.
  const VelocityControl at_tau{.v = 0.4, .omega = 0.15, .dt = 0.2};
  ExpectNear(VelocityMotionCovariance(Pose2(1, 2, 0.5), at_tau, per_time),
             VelocityMotionCovariance(Pose2(1, 2, 0.5), at_tau, per_step), 1e-15);
}

TEST(VelocityMotionModel, RateIndependentNoiseStaysDefiniteAtRepeatedStamps) {
  VelocityNoise noise;
  noise.noise_time_constant = 0.5;
  for (const double dt : {0.0, 1e-9, 1e-4}) {
    const Eigen::Matrix3d covariance =
        VelocityMotionCovariance(Pose2(1, 2, 3), VelocityControl{.v = 1, .omega = 0.5, .dt = dt},
                                 noise);
    EXPECT_TRUE(covariance.allFinite()) << dt;
    EXPECT_EQ(Eigen::LLT<Eigen::Matrix3d>(covariance).info(), Eigen::Success) << dt;
    // Never below the floor of dt = 1e-3 tau.
    EXPECT_GE(covariance(0, 0), 1e-3 * 1e-6 * (1.0 - 1e-12)) << dt;
  }
}

}  // namespace
}  // namespace graphslam::core
