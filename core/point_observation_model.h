// A point feature observed in the robot frame (g2o EDGE_SE2_XY).
//
//   e = R(theta)^T (m - t) - z,   t = (x, y)
//   de/dt = -R^T,  de/dtheta = dR^T/dtheta (m - t),  de/dm = R^T
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se2.h"

namespace graphslam::core {

void EvaluatePointObservation(const Pose2& pose, const Point2& feature,
                              const Eigen::Vector2d& measurement, Eigen::Vector2d* residual,
                              Eigen::Matrix<double, 2, 3>* jacobian_pose,
                              Eigen::Matrix2d* jacobian_feature);

// m = t + R(theta) z: the feature position implied by one observation.
Point2 InvertPointObservation(const Pose2& pose, const Eigen::Vector2d& measurement);

}  // namespace graphslam::core
