#include "core/relative_pose_model.h"

#include <cmath>

namespace graphslam::core {
namespace {

// d R(theta)^T / d theta for R^T = [c s; -s c].
Eigen::Matrix2d RotationTransposeDerivative(double theta) {
  const double c = std::cos(theta), s = std::sin(theta);
  Eigen::Matrix2d derivative;
  derivative << -s, c, -c, -s;
  return derivative;
}

}  // namespace

// With d = X_i^{-1} X_j = (R_i^T (t_j - t_i), th_j - th_i) and Z = (z_t, z_th):
//   e_t  = R_z^T (R_i^T (t_j - t_i) - z_t)
//   e_th = wrap(th_j - th_i - z_th)
// so that
//   de_t/dt_i = -R_z^T R_i^T,   de_t/dth_i = R_z^T dR_i^T/dth (t_j - t_i),
//   de_t/dt_j =  R_z^T R_i^T,   de_th/dth_i = -1,   de_th/dth_j = 1.
void EvaluateRelativePose(const Pose2& from, const Pose2& to, const Pose2& measurement,
                          Eigen::Vector3d* residual, Eigen::Matrix3d* jacobian_from,
                          Eigen::Matrix3d* jacobian_to) {
  if (residual != nullptr) {
    *residual = Between(measurement, Between(from, to));
  }
  if (jacobian_from == nullptr && jacobian_to == nullptr) return;
  const Eigen::Matrix2d measurement_rotation_t = Rotation2(measurement.z()).transpose();
  const Eigen::Matrix2d rotation = measurement_rotation_t * Rotation2(from.z()).transpose();
  if (jacobian_from != nullptr) {
    jacobian_from->setZero();
    jacobian_from->block<2, 2>(0, 0) = -rotation;
    jacobian_from->block<2, 1>(0, 2) = measurement_rotation_t *
                                       RotationTransposeDerivative(from.z()) *
                                       (to.head<2>() - from.head<2>());
    (*jacobian_from)(2, 2) = -1.0;
  }
  if (jacobian_to != nullptr) {
    jacobian_to->setZero();
    jacobian_to->block<2, 2>(0, 0) = rotation;
    (*jacobian_to)(2, 2) = 1.0;
  }
}

void EvaluateRelativePoseIncrementFactors(const Pose2& from, const Pose2& to,
                                          const Pose2& measurement, Eigen::Vector3d* residual,
                                          RelativePoseIncrementFactors* factors) {
  // The residual's arithmetic is Between(measurement, Between(from, to))'s.
  const Eigen::Matrix2d measurement_rotation_t = Rotation2(measurement.z()).transpose();
  const Eigen::Vector2d p = Rotation2(from.z()).transpose() * (to.head<2>() - from.head<2>());
  const double angle = WrapAngle(WrapAngle(to.z() - from.z()) - measurement.z());
  residual->head<2>() = measurement_rotation_t * (p - measurement.head<2>());
  residual->z() = angle;
  if (factors == nullptr) return;
  factors->q = measurement_rotation_t;
  factors->u = measurement_rotation_t * Eigen::Vector2d(p.y(), -p.x());
  factors->g = Rotation2(angle);
}

void EvaluateRelativePoseIncrement(const Pose2& from, const Pose2& to, const Pose2& measurement,
                                   Eigen::Vector3d* residual, Eigen::Matrix3d* jacobian_from,
                                   Eigen::Matrix3d* jacobian_to) {
  Eigen::Vector3d e;
  RelativePoseIncrementFactors f;
  const bool jacobians = jacobian_from != nullptr || jacobian_to != nullptr;
  EvaluateRelativePoseIncrementFactors(from, to, measurement, &e, jacobians ? &f : nullptr);
  if (residual != nullptr) *residual = e;
  if (jacobian_from != nullptr) {
    jacobian_from->setZero();
    jacobian_from->block<2, 2>(0, 0) = -f.q;
    jacobian_from->block<2, 1>(0, 2) = f.u;
    (*jacobian_from)(2, 2) = -1.0;
  }
  if (jacobian_to != nullptr) {
    jacobian_to->setZero();
    jacobian_to->block<2, 2>(0, 0) = f.g;
    (*jacobian_to)(2, 2) = 1.0;
  }
}

}  // namespace graphslam::core
