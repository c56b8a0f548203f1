// GPS position fix of a pose (paper eq. 3): z is the robot position (x, y) in
// the map's local frame (a local ENU frame for real fixes).
//
//   e = (x, y) - z,   de/dpose = [I_2 | 0]
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se2.h"

namespace graphslam::core {

void EvaluateGps(const Pose2& pose, const Eigen::Vector2d& measurement,
                 Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 3>* jacobian_pose);

}  // namespace graphslam::core
