// Exponential and logarithm maps of SO(3) and SE(3), the solver's retraction
// on 3-D poses, and the adjoint (core/se3.h holds the Pose3 type).
//
// Tangent vectors are 6-vectors d = (rho, phi): translation part first, then
// the rotation vector (axis * angle), as in g2o's and GTSAM's Pose3.
//
//   ExpSO3(phi)  = (cos(|phi|/2), sin(|phi|/2) phi/|phi|)            (quaternion)
//   LogSO3(q)    = 2 atan2(|v|, w) v/|v|,  q = (w, v) taken with w >= 0
//   V(phi)       = I + (1 - cos a)/a^2 [phi]x + (a - sin a)/a^3 [phi]x^2,  a = |phi|
//   ExpSE3(d)    = (ExpSO3(phi), V(phi) rho)
//   LogSE3(T)    = (V(phi)^-1 t, phi),  phi = LogSO3(T.q)
//   V^-1(phi)    = I - 1/2 [phi]x + (1/a^2)(1 - a sin a / (2 (1 - cos a))) [phi]x^2
// Below a = 1e-4 (ExpSO3/LogSO3) and 0.1 (V, V^-1) the coefficients are
// replaced by their Taylor series, exact to double precision there (the closed
// forms lose digits to cancellation for small a).
//
// The retraction (the solver's increment, the convention every 3-D Jacobian
// in core/ is taken against):
//   x (+) d = x * ExpSE3(d)        (right / body-frame perturbation)
// so for a residual e(x), J = d e(x * Exp(d)) / d d at d = 0. g2o's VertexSE3
// oplus uses (t, qvec) increments instead; both agree to first order at d = 0
// up to the rotation scale, and the optimum does not depend on the retraction.
//
//   Adjoint(T) = [R  [t]x R; 0  R]:  T Exp(d) T^-1 = Exp(Adjoint(T) d)
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "core/se3.h"

namespace graphslam::core {

using Matrix6d = Eigen::Matrix<double, 6, 6>;

inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(), v.z(), 0.0, -v.x(), -v.y(), v.x(), 0.0;
  return m;
}

inline Eigen::Quaterniond ExpSO3(const Eigen::Vector3d& phi) {
  const double a2 = phi.squaredNorm();
  const double a = std::sqrt(a2);
  double w, k;  // q = (w, k phi)
  if (a < 1e-4) {
    w = 1.0 - a2 / 8.0;         // cos(a/2) = 1 - a^2/8 + O(a^4)
    k = 0.5 - a2 / 48.0;        // sin(a/2)/a = 1/2 - a^2/48 + O(a^4)
  } else {
    w = std::cos(0.5 * a);
    k = std::sin(0.5 * a) / a;
  }
  Eigen::Quaterniond q(w, k * phi.x(), k * phi.y(), k * phi.z());
  return q.normalized();
}

// The rotation vector of q, with |phi| <= pi (q and -q give the same phi).
inline Eigen::Vector3d LogSO3(const Eigen::Quaterniond& q_in) {
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double s = v.norm();
  const double w = q.w();
  if (s < 1e-4 * w) {
    // 2 atan(s/w)/s = (2/w)(1 - s^2/(3 w^2)) + O(s^4)
    return (2.0 / w) * (1.0 - s * s / (3.0 * w * w)) * v;
  }
  return (2.0 * std::atan2(s, w) / s) * v;
}

// The left Jacobian V(phi) of SO(3) (the translation part of ExpSE3).
inline Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi) {
  const double a2 = phi.squaredNorm();
  const double a = std::sqrt(a2);
  const Eigen::Matrix3d k = Skew(phi);
  double c1, c2;
  if (a < 0.1) {
    // Taylor series to a^6: the next terms are below 1e-16 for a < 0.1.
    c1 = 0.5 - a2 / 24.0 + a2 * a2 / 720.0 - a2 * a2 * a2 / 40320.0;         // (1 - cos a)/a^2
    c2 = 1.0 / 6.0 - a2 / 120.0 + a2 * a2 / 5040.0 - a2 * a2 * a2 / 362880.0;  // (a - sin a)/a^3
  } else {
    const double s = std::sin(0.5 * a);
    c1 = 2.0 * s * s / a2;  // 1 - cos a = 2 sin^2(a/2), without cancellation
    c2 = (a - std::sin(a)) / (a2 * a);
  }
  return Eigen::Matrix3d::Identity() + c1 * k + c2 * k * k;
}

inline Eigen::Matrix3d InverseLeftJacobianSO3(const Eigen::Vector3d& phi) {
  const double a2 = phi.squaredNorm();
  const double a = std::sqrt(a2);
  const Eigen::Matrix3d k = Skew(phi);
  double c2;  // (1 - (a/2) cot(a/2)) / a^2
  if (a < 0.1) {
    c2 = 1.0 / 12.0 + a2 / 720.0 + a2 * a2 / 30240.0 + a2 * a2 * a2 / 1209600.0;
  } else {
    const double h = 0.5 * a;
    c2 = (1.0 - h * std::cos(h) / std::sin(h)) / a2;
  }
  return Eigen::Matrix3d::Identity() - 0.5 * k + c2 * k * k;
}

inline Pose3 ExpSE3(const Vector6d& d) {
  Pose3 out;
  const Eigen::Vector3d phi = d.tail<3>();
  out.q = ExpSO3(phi);
  out.t = LeftJacobianSO3(phi) * d.head<3>();
  return out;
}

inline Vector6d LogSE3(const Pose3& pose) {
  Vector6d d;
  const Eigen::Vector3d phi = LogSO3(pose.q);
  d.tail<3>() = phi;
  d.head<3>() = InverseLeftJacobianSO3(phi) * pose.t;
  return d;
}

// The solver's increment on a 3-D pose: x (+) d = x * Exp(d).
inline Pose3 RetractPose3(const Pose3& x, const Vector6d& d) { return Compose(x, ExpSE3(d)); }

inline Matrix6d Adjoint(const Pose3& pose) {
  const Eigen::Matrix3d r = pose.rotation();
  Matrix6d m = Matrix6d::Zero();
  m.topLeftCorner<3, 3>() = r;
  m.topRightCorner<3, 3>() = Skew(pose.t) * r;
  m.bottomRightCorner<3, 3>() = r;
  return m;
}

}  // namespace graphslam::core
