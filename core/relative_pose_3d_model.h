// Relative-pose constraint between two 3-D poses (g2o EDGE_SE3:QUAT, iSAM
// EDGE3): z is pose j in the frame of pose i.
//
//   E = z^-1 (x_i^-1 x_j)                       (identity when x_i, x_j agree with z)
//   e = [ t_E ; vec(q_E) ],  q_E taken with w >= 0
// exactly g2o's EdgeSE3::computeError (toVectorMQT), so the information
// matrices of g2o files mean what they mean in g2o and chi2 = e^T Omega e is
// g2o's chi2 (the reference optima of INDEX.md are reached in this
// convention, not with 2 vec(q); docs/3d.md "Error convention"). vec(q) =
// sin(a/2) axis is HALF the rotation vector to second order: an information
// matrix stated on angles (iSAM) is scaled by 4 on its rotation block when
// read (storage/isam_3d_reader.h).
//
// Jacobians against the retraction x (+) d = x Exp(d) (core/se3_lie.h):
//   D(E)  = d e(E Exp(d))/dd = [ R_E  0 ; 0  (w I + [v]x)/2 ],  q_E = (w, v)
//   J_j   = D(E)                                  (E Exp(d_j))
//   J_i   = -D(E) Adjoint(x_j^-1 x_i)              (x_i Exp(d_i) gives
//            E Exp(-Adjoint(E^-1 z^-1) d_i), E^-1 z^-1 = x_j^-1 x_i)
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se3_lie.h"

namespace graphslam::core {

// e = [t; vec(q)] of a relative transform (the residual of a pose that
// should be the identity).
inline Vector6d PoseError3(const Pose3& e_pose) {
  Eigen::Quaterniond q = e_pose.q.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  Vector6d e;
  e.head<3>() = e_pose.t;
  e.tail<3>() = q.vec();
  return e;
}

// The Jacobians in the factors they are made of, for products that use their
// structure (core/pose_factors_3d.cc): J_j = D(E) = diag(d_t, d_q) and
// J_i = -D(E) Adjoint(x_j^-1 x_i), Adjoint = [r s; 0 r] (core/se3_lie.h).
struct RelativePose3Factors {
  Eigen::Matrix3d d_t;  // R_E
  Eigen::Matrix3d d_q;  // (w I + [v]x) / 2
  Eigen::Matrix3d r;    // rotation of x_j^-1 x_i
  Eigen::Matrix3d s;    // [t]x r, t its translation
};

// The residual (when wanted) and the Jacobians' factors.
inline void EvaluateRelativePose3Factors(const Pose3& xi, const Pose3& xj, const Pose3& z,
                                         Vector6d* residual, RelativePose3Factors* factors) {
  const Pose3 e_pose = Between(z, Between(xi, xj));
  if (residual != nullptr) *residual = PoseError3(e_pose);
  Eigen::Quaterniond q = e_pose.q.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  factors->d_t = q.toRotationMatrix();
  factors->d_q = 0.5 * (q.w() * Eigen::Matrix3d::Identity() + Skew(q.vec()));
  const Pose3 ji = Between(xj, xi);
  factors->r = ji.rotation();
  factors->s = Skew(ji.t) * factors->r;
}

// Any of the outputs may be nullptr.
inline void EvaluateRelativePose3(const Pose3& xi, const Pose3& xj, const Pose3& z,
                                  Vector6d* residual, Matrix6d* jacobian_i,
                                  Matrix6d* jacobian_j) {
  if (jacobian_i == nullptr && jacobian_j == nullptr) {
    if (residual != nullptr) *residual = PoseError3(Between(z, Between(xi, xj)));
    return;
  }
  RelativePose3Factors f;
  EvaluateRelativePose3Factors(xi, xj, z, residual, &f);
  Matrix6d d = Matrix6d::Zero();
  d.topLeftCorner<3, 3>() = f.d_t;
  d.bottomRightCorner<3, 3>() = f.d_q;
  if (jacobian_j != nullptr) *jacobian_j = d;
  if (jacobian_i != nullptr) {
    Matrix6d adjoint = Matrix6d::Zero();
    adjoint.topLeftCorner<3, 3>() = f.r;
    adjoint.topRightCorner<3, 3>() = f.s;
    adjoint.bottomRightCorner<3, 3>() = f.r;
    *jacobian_i = -d * adjoint;
  }
}

}  // namespace graphslam::core
