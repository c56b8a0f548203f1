// GPS / position prior of a 3-D pose (g2o EDGE_SE3_XYZPRIOR): z is the
// position of the pose in the world frame (a local ENU frame for real fixes).
//
//   e = t - z
// Against x Exp(d), d = (rho, phi): t -> t + R rho, so de/dd = [R | 0].
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se3_lie.h"

namespace graphslam::core {

inline void EvaluateGps3(const Pose3& pose, const Eigen::Vector3d& measurement,
                         Eigen::Vector3d* residual, Eigen::Matrix<double, 3, 6>* jacobian_pose) {
  if (residual != nullptr) *residual = pose.t - measurement;
  if (jacobian_pose != nullptr) {
    jacobian_pose->leftCols<3>() = pose.rotation();
    jacobian_pose->rightCols<3>().setZero();
  }
}

}  // namespace graphslam::core
