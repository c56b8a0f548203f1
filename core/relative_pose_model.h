// Relative-pose odometry (g2o EDGE_SE2, iSAM ODOMETRY/EDGE2).
//
// A measurement z = (dx, dy, dth) of pose j in the frame of pose i. The residual
// is g2o's:
//   e = t2v( Z^{-1} (X_i^{-1} X_j) ),   angle wrapped to (-pi, pi]
// so that chi2 = e^T Omega e matches g2o's numbers exactly.
// Jacobians de/dx_i (3x3) and de/dx_j (3x3) are analytic, with respect to the
// plain (x, y, theta) parameterization used for the update x <- x + delta.
//
// EvaluateRelativePoseIncrement gives the same residual and the Jacobians
// with respect to the solver's body-frame increments (core/se2.h,
// RetractPose), J_d = J_xytheta * RetractionJacobian, in closed form. With
// p = R_i^T (t_j - t_i):
//   de/dd_i = [ -R_z^T   R_z^T (p_y, -p_x)^T ;  0 0 -1 ]
//   de/dd_j = [ R(e_th)  0 ;                   0 0  1 ]
// (R_z^T R_i^T R_j = R(th_j - th_i - z_th) = R(e_th)), three sine-cosine
// pairs per call where the (x, y, theta) Jacobians and two retraction
// Jacobians take seven.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se2.h"

namespace graphslam::core {

void EvaluateRelativePose(const Pose2& from, const Pose2& to, const Pose2& measurement,
                          Eigen::Vector3d* residual, Eigen::Matrix3d* jacobian_from,
                          Eigen::Matrix3d* jacobian_to);

void EvaluateRelativePoseIncrement(const Pose2& from, const Pose2& to, const Pose2& measurement,
                                   Eigen::Vector3d* residual, Eigen::Matrix3d* jacobian_from,
                                   Eigen::Matrix3d* jacobian_to);

// The increment Jacobians in the pieces they are made of, for products that
// skip their zeros (core/pose_factors.cc): de/dd_i = [ -q  u ; 0 0 -1 ] and
// de/dd_j = [ g  0 ; 0 0  1 ], with q = R_z^T, u = R_z^T (p_y, -p_x)^T and
// g = R(e_th).
struct RelativePoseIncrementFactors {
  Eigen::Matrix2d q;
  Eigen::Vector2d u;
  Eigen::Matrix2d g;
};

// The residual (EvaluateRelativePoseIncrement's, bit for bit) and the pieces.
void EvaluateRelativePoseIncrementFactors(const Pose2& from, const Pose2& to,
                                          const Pose2& measurement, Eigen::Vector3d* residual,
                                          RelativePoseIncrementFactors* factors);

}  // namespace graphslam::core
