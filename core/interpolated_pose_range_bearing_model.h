// Range-bearing measurement of another robot at a time between two of its
// poses: robot A reads robot B's barcode at stamp t, and B has no pose at t
// but poses b0 at t0 and b1 at t1 with t0 < t < t1. A three-pose factor.
//
// B's position at t is interpolated linearly between b0 and b1:
//
//   alpha = (t - t0) / (t1 - t0)  in [0, 1]
//   p(alpha) = (1 - alpha) (x_b0, y_b0) + alpha (x_b1, y_b1)
//
// and the residual is the one of core/pose_range_bearing_model.h with the
// marker at p(alpha) (a the observing pose = (x_a, y_a, theta_a)):
//
//   d = p(alpha) - (x_a, y_a),  q = d^T d
//   e = ( sqrt(q) - r,  wrap(atan2(d_y, d_x) - theta_a - phi) )
//
// Jacobians with respect to (x, y, theta) of a, b0 and b1, with J_p the
// range-bearing Jacobian with respect to the marker position,
// J_p = [ d_x/sqrt(q)  d_y/sqrt(q) ; -d_y/q  d_x/q ]:
//   de/da  = [ -d_x/sqrt(q)  -d_y/sqrt(q)   0 ]
//            [  d_y/q        -d_x/q        -1 ]
//   de/db0 = (1 - alpha) [ J_p  0 ]
//   de/db1 =       alpha [ J_p  0 ]
// The headings of b0 and b1 do not enter (the marker sits on B's origin, and
// only B's position is interpolated). At alpha = 0, p = (x_b0, y_b0) exactly
// and e, de/da, de/db0 are those of EvaluatePoseRangeBearing(a, b0) bit for
// bit, de/db1 = 0; alpha = 1 is the same with b1.
//
// Why linear in position and not the SE(2) geodesic b0 (+) alpha Log(b0^-1 b1)
// (the arc of constant (v, omega) that the velocity motion model drives):
// the chord and the arc differ at most by the sagitta v dt * (omega dt) / 8,
// 2.5e-5 m for MRCLAM's robots (v < 0.5 m/s, |omega| < 1 rad/s) over a
// 0.02 s gap, 0.0006 m over 0.1 s, far below the camera's range noise of
// several cm; the linear form has constant Jacobians in b0 and b1.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se2.h"

namespace graphslam::core {

// (1 - alpha) (x_b0, y_b0) + alpha (x_b1, y_b1).
Point2 InterpolatePosition(const Pose2& before, const Pose2& after, double alpha);

// Returns false (outputs untouched) when the observer's position coincides
// with p(alpha) (q below 1e-18), where the bearing is undefined.
bool EvaluateInterpolatedPoseRangeBearing(const Pose2& observer, const Pose2& observed_before,
                                          const Pose2& observed_after, double alpha,
                                          const Eigen::Vector2d& measurement,
                                          Eigen::Vector2d* residual,
                                          Eigen::Matrix<double, 2, 3>* jacobian_observer,
                                          Eigen::Matrix<double, 2, 3>* jacobian_before,
                                          Eigen::Matrix<double, 2, 3>* jacobian_after);

}  // namespace graphslam::core
