// Bearing-only measurement of a point feature (a camera column, a direction
// finder): the range part of the range-bearing model dropped.
//
//   delta = m - (x, y),  q = delta^T delta
//   h(x_t, m_j) = atan2(delta_y, delta_x) - theta
//   e = wrap(h - phi)
//   J = (dy/q, -dx/q, -1 | -dy/q, dx/q)   with respect to (x, y, theta | m)
//
// One measured value in the 2-D observation slot (core/observation_models.h):
// z = (phi, 0), information diag(w, 1); the second residual is 0 and its
// Jacobian rows are 0, so only w * e^2 enters chi2 and the normal equations.
//
// First sight: one bearing fixes the ray, not the range. The feature is placed
// on the ray at kFirstSightRange; the solve recovers the range from the other
// views, so every bearing-only feature needs two views with a baseline that
// is not along the ray (otherwise its 2x2 information block is singular and
// the Schur step reports it).
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "core/se2.h"

namespace graphslam::core {

struct BearingModel {
  static constexpr const char* kName = "bearing";
  static constexpr const char* kNativeLogTag = "B";
  static constexpr int kMeasurementDim = 1;
  static constexpr const char* kMeasurementFields[1] = {"bearing"};
  static constexpr const char* kMeasurementRule = "a finite bearing";
  // Distance along the ray of a feature placed at first sight [m].
  static constexpr double kFirstSightRange = 1.0;
  // Below this squared distance the bearing is undefined.
  static constexpr double kMinSquaredRange = 1e-18;

  static int InvalidMeasurementField(const Eigen::Vector2d&) { return -1; }

  // false (outputs untouched) when the feature is on the robot (q < 1e-18).
  static bool Evaluate(const Pose2& pose, const Point2& feature, const Eigen::Vector2d& z,
                       Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 3>* jacobian_pose,
                       Eigen::Matrix2d* jacobian_feature) {
    const Eigen::Vector2d delta = feature - pose.head<2>();
    const double q = delta.squaredNorm();
    if (!(q >= kMinSquaredRange)) return false;  // also rejects NaN
    const double dx = delta.x(), dy = delta.y();
    if (residual != nullptr) {
      *residual << WrapAngle(std::atan2(dy, dx) - pose.z() - z(0)), 0.0;
    }
    if (jacobian_pose != nullptr) {
      *jacobian_pose << dy / q, -dx / q, -1.0,  //
          0.0, 0.0, 0.0;
    }
    if (jacobian_feature != nullptr) {
      *jacobian_feature << -dy / q, dx / q,  //
          0.0, 0.0;
    }
    return true;
  }

  // m = (x, y) + kFirstSightRange (cos(theta + phi), sin(theta + phi)).
  static Point2 Invert(const Pose2& pose, const Eigen::Vector2d& z) {
    const double angle = pose.z() + z(0);
    return pose.head<2>() + kFirstSightRange * Eigen::Vector2d(std::cos(angle), std::sin(angle));
  }
};

}  // namespace graphslam::core
