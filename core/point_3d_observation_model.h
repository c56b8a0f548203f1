// A 3-D point feature observed in the sensor (pose) frame (g2o
// EDGE_SE3_TRACKXYZ with identity offset, iSAM POINT3).
//
//   e = R^T (m - t) - z
// Against the pose retraction x Exp(d), d = (rho, phi), and m (+) dm = m + dm:
//   x Exp(d) moves R -> R (I + [phi]x), t -> t + R rho, so
//   R^T(m - t) -> p - rho - [phi]x p = p - rho + [p]x phi,   p = R^T (m - t)
//   de/drho = -I,  de/dphi = [p]x,  de/dm = R^T
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se3_lie.h"

namespace graphslam::core {

// Any of the outputs may be nullptr.
inline void EvaluatePoint3Observation(const Pose3& pose, const Point3& feature,
                                      const Eigen::Vector3d& measurement,
                                      Eigen::Vector3d* residual,
                                      Eigen::Matrix<double, 3, 6>* jacobian_pose,
                                      Eigen::Matrix3d* jacobian_feature) {
  const Eigen::Matrix3d rt = pose.rotation().transpose();
  const Eigen::Vector3d p = rt * (feature - pose.t);
  if (residual != nullptr) *residual = p - measurement;
  if (jacobian_pose != nullptr) {
    jacobian_pose->leftCols<3>() = -Eigen::Matrix3d::Identity();
    jacobian_pose->rightCols<3>() = Skew(p);
  }
  if (jacobian_feature != nullptr) *jacobian_feature = rt;
}

// m = t + R z: the feature position implied by one observation.
inline Point3 InvertPoint3Observation(const Pose3& pose, const Eigen::Vector3d& measurement) {
  return TransformPoint(pose, measurement);
}

}  // namespace graphslam::core
