// Relative-pose odometry (g2o EDGE_SE2, iSAM ODOMETRY/EDGE2).
//
// A measurement z = (dx, dy, dth) of pose j in the frame of pose i. The residual
// is g2o's:
//   e = t2v( Z^{-1} (X_i^{-1} X_j) ),   angle wrapped to (-pi, pi]
// so that chi2 = e^T Omega e matches g2o's numbers exactly.
// Jacobians de/dx_i (3x3) and de/dx_j (3x3) are analytic, with respect to the
// plain (x, y, theta) parameterization used for the update x <- x + delta.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se2.h"

namespace graphslam::core {

void EvaluateRelativePose(const Pose2& from, const Pose2& to, const Pose2& measurement,
                          Eigen::Vector3d* residual, Eigen::Matrix3d* jacobian_from,
                          Eigen::Matrix3d* jacobian_to);

}  // namespace graphslam::core
