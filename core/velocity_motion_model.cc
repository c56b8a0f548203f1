#include "core/velocity_motion_model.h"

#include <algorithm>
#include <cmath>

namespace graphslam::core {
namespace {

// The translation of one step, written so that omega = 0 is not special:
//
//   (dx, dy) = v dt R(theta) (S(a), C(a)),   a = omega dt,
//   S(a) = sin(a) / a,   C(a) = (1 - cos(a)) / a = 2 sin^2(a/2) / a,
//
// which equals the paper's (-v/w sin th + v/w sin(th + w dt), v/w cos th - v/w cos(th + w dt))
// for a != 0 and the straight line (v dt cos th, v dt sin th) at a = 0.
// Below kSeriesThreshold the Taylor series are used; their truncation error
// there is below a^8 / 8! < 1e-20 and the closed forms would lose digits in
// dS/da, dC/da to cancellation (a cos a - sin a ~ a^3 / 3).
constexpr double kSeriesThreshold = 1e-2;

struct ArcTerms {
  double s = 1.0;   // S(a)
  double c = 0.0;   // C(a)
  double ds = 0.0;  // dS/da
  double dc = 0.5;  // dC/da
};

ArcTerms ComputeArcTerms(double a) {
  ArcTerms terms;
  const double a2 = a * a;
  if (std::abs(a) < kSeriesThreshold) {
    // S = 1 - a^2/6 + a^4/120 - a^6/5040
    // C = a/2 - a^3/24 + a^5/720 - a^7/40320
    terms.s = 1.0 - a2 / 6.0 * (1.0 - a2 / 20.0 * (1.0 - a2 / 42.0));
    terms.c = a / 2.0 * (1.0 - a2 / 12.0 * (1.0 - a2 / 30.0 * (1.0 - a2 / 56.0)));
    // dS/da = -a/3 + a^3/30 - a^5/840 + a^7/45360
    // dC/da = 1/2 - a^2/8 + a^4/144 - a^6/5760
    terms.ds = -a / 3.0 * (1.0 - a2 / 10.0 * (1.0 - a2 / 28.0 * (1.0 - a2 / 54.0)));
    terms.dc = 0.5 * (1.0 - a2 / 4.0 * (1.0 - a2 / 18.0 * (1.0 - a2 / 40.0)));
  } else {
    const double sin_a = std::sin(a);
    const double cos_a = std::cos(a);
    const double half_sin = std::sin(0.5 * a);
    terms.s = sin_a / a;
    terms.c = 2.0 * half_sin * half_sin / a;
    terms.ds = (cos_a - terms.s) / a;
    terms.dc = (sin_a - terms.c) / a;
  }
  return terms;
}

// (dx, dy) of one step, see above.
Eigen::Vector2d Translation(double theta, const VelocityControl& control, const ArcTerms& terms) {
  return control.v * control.dt * (Rotation2(theta) * Eigen::Vector2d(terms.s, terms.c));
}

}  // namespace

Pose2 PredictVelocityMotion(const Pose2& previous, const VelocityControl& control) {
  const ArcTerms terms = ComputeArcTerms(control.omega * control.dt);
  Pose2 out;
  out.head<2>() = previous.head<2>() + Translation(previous.z(), control, terms);
  out.z() = WrapAngle(previous.z() + control.omega * control.dt);
  return out;
}

Eigen::Matrix3d VelocityMotionJacobian(const Pose2& previous, const VelocityControl& control) {
  const ArcTerms terms = ComputeArcTerms(control.omega * control.dt);
  const Eigen::Vector2d delta = Translation(previous.z(), control, terms);
  // d(dx, dy)/dtheta = (-dy, dx): the corrected third column of Table 2 l.6,
  // (-v/w cos th + v/w cos(th + w dt), -v/w sin th + v/w sin(th + w dt)).
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Identity();
  jacobian(0, 2) = -delta.y();
  jacobian(1, 2) = delta.x();
  return jacobian;
}

Eigen::Matrix3d VelocityControlJacobian(const Pose2& previous, const VelocityControl& control) {
  const double dt = control.dt;
  const ArcTerms terms = ComputeArcTerms(control.omega * dt);
  const Eigen::Matrix2d rotation = Rotation2(previous.z());
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Zero();
  // d/dv: dt R (S, C); theta does not depend on v.
  jacobian.block<2, 1>(0, 0) = dt * (rotation * Eigen::Vector2d(terms.s, terms.c));
  // d/domega: v dt R (S', C') da/domega with da/domega = dt; dtheta/domega = dt.
  jacobian.block<2, 1>(0, 1) =
      control.v * dt * dt * (rotation * Eigen::Vector2d(terms.ds, terms.dc));
  jacobian(2, 1) = dt;
  // d/dgamma: the final rotation gamma dt only turns the robot.
  jacobian(2, 2) = dt;
  return jacobian;
}

Pose2 InverseVelocityMotion(const Pose2& current, const VelocityControl& control) {
  const ArcTerms terms = ComputeArcTerms(control.omega * control.dt);
  Pose2 previous;
  previous.z() = WrapAngle(current.z() - control.omega * control.dt);
  previous.head<2>() = current.head<2>() - Translation(previous.z(), control, terms);
  return previous;
}

void EvaluateVelocityMotion(const Pose2& previous, const Pose2& current,
                            const VelocityControl& control, Eigen::Vector3d* residual,
                            Eigen::Matrix3d* jacobian_previous, Eigen::Matrix3d* jacobian_current) {
  if (residual != nullptr) {
    const Pose2 predicted = PredictVelocityMotion(previous, control);
    residual->head<2>() = current.head<2>() - predicted.head<2>();
    (*residual)(2) = WrapAngle(current.z() - predicted.z());
  }
  if (jacobian_previous != nullptr) {
    *jacobian_previous = -VelocityMotionJacobian(previous, control);
  }
  if (jacobian_current != nullptr) jacobian_current->setIdentity();
}

namespace {

// The factors on V M V^T and on the floor (header: per step or per unit time).
struct NoiseScales {
  double control = 1.0;
  double floor = 1.0;
};

NoiseScales StepNoiseScales(double dt, double tau) {
  if (!(tau > 0.0)) return {};
  // Below 1e-3 tau the floor stops shrinking, so repeated stamps keep R
  // definite; V M V^T is ~ dt^2, so tau/dt on it stays finite, and at dt = 0
  // V is zero and so is its term.
  const double floor_dt = std::max(std::abs(dt), 1e-3 * tau);
  return {dt != 0.0 ? tau / std::abs(dt) : 0.0, floor_dt / tau};
}

}  // namespace

Eigen::Matrix3d VelocityMotionCovariance(const Pose2& previous, const VelocityControl& control,
                                         const VelocityNoise& noise) {
  const double v2 = control.v * control.v;
  const double w2 = control.omega * control.omega;
  const Eigen::Vector3d control_variance(noise.alpha[0] * v2 + noise.alpha[1] * w2,
                                         noise.alpha[2] * v2 + noise.alpha[3] * w2,
                                         noise.alpha[4] * v2 + noise.alpha[5] * w2);
  const Eigen::Matrix3d v = VelocityControlJacobian(previous, control);
  const NoiseScales scales = StepNoiseScales(control.dt, noise.noise_time_constant);
  Eigen::Matrix3d covariance =
      scales.control * (v * control_variance.asDiagonal() * v.transpose());
  // Exactly symmetric, whatever the rounding of the product.
  covariance = (0.5 * (covariance + covariance.transpose())).eval();
  // The floor is added (not max'ed) so that R is positive definite even when
  // V M V^T is singular (robot standing still, or dt = 0).
  covariance(0, 0) += scales.floor * noise.min_sigma_xy * noise.min_sigma_xy;
  covariance(1, 1) += scales.floor * noise.min_sigma_xy * noise.min_sigma_xy;
  covariance(2, 2) += scales.floor * noise.min_sigma_theta * noise.min_sigma_theta;
  return covariance;
}

}  // namespace graphslam::core
