// Range-bearing measurement of another pose's position: one robot seeing
// another (a barcode on the observed robot, MRCLAM), a pose-pair factor.
//
// The observing pose a = (x_a, y_a, theta_a) measures z = (r, phi) of the
// observed pose b = (x_b, y_b, theta_b) at the same instant. The marker is at
// b's origin, so the model is the range-bearing model of a point feature
// (core/range_bearing_model.h) with the feature m = (x_b, y_b):
//
//   d = (x_b - x_a, y_b - y_a),  q = d^T d
//   e = ( sqrt(q) - r,  wrap(atan2(d_y, d_x) - theta_a - phi) )
//
// Jacobians with respect to (x_a, y_a, theta_a) and (x_b, y_b, theta_b):
//   de/da = [ -d_x/sqrt(q)  -d_y/sqrt(q)   0 ]
//           [  d_y/q        -d_x/q        -1 ]
//   de/db = [  d_x/sqrt(q)   d_y/sqrt(q)   0 ]
//           [ -d_y/q         d_x/q         0 ]
// The observed heading theta_b does not enter (the marker sits on b's origin).
//
// The observed pose is the one at the measurement's time stamp
// (tools/job/robot_sightings.h); on MRCLAM's 50 Hz data every run is sampled
// on the same 0.02 s grid, so there is one. When the observed robot has no
// pose at the stamp, its position is interpolated between the poses around it
// (core/interpolated_pose_range_bearing_model.h, which is this model at
// alpha = 0).
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/se2.h"

namespace graphslam::core {

// Returns false (outputs untouched) when the two positions coincide (q below
// 1e-18), where the bearing is undefined.
bool EvaluatePoseRangeBearing(const Pose2& observer, const Pose2& observed,
                              const Eigen::Vector2d& measurement, Eigen::Vector2d* residual,
                              Eigen::Matrix<double, 2, 3>* jacobian_observer,
                              Eigen::Matrix<double, 2, 3>* jacobian_observed);

}  // namespace graphslam::core
