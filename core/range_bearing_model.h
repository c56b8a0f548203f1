// Range-bearing measurement of a point feature (paper eq. 1, Table 2 l.12-17).
//
//   delta = m - (x, y),  q = delta^T delta
//   h(x_t, m_j) = ( sqrt(q), atan2(delta_y, delta_x) - theta )
//   e = ( sqrt(q) - r, wrap(atan2(delta_y, delta_x) - theta - phi) )
//
// Jacobian of h (and of e) with respect to (x, y, theta, m_x, m_y), Table 2 l.17
// with the corrected rows (errata: docs/design.md):
//   range:   ( -dx/sqrt(q), -dy/sqrt(q),  0,  dx/sqrt(q), dy/sqrt(q) )
//   bearing: (  dy/q,       -dx/q,       -1, -dy/q,       dx/q       )
// The bearing residual is wrapped, so a bearing across +-pi is handled.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "core/se2.h"

namespace graphslam::core {

// Returns false (and leaves outputs untouched) when the feature coincides with
// the robot position (q below 1e-18), where the bearing is undefined.
// Inline: a streaming pass evaluates every observation up to three times,
// and inlined the unused outputs (nullptr) are not computed.
inline bool EvaluateRangeBearing(const Pose2& pose, const Point2& feature,
                                 const Eigen::Vector2d& measurement, Eigen::Vector2d* residual,
                                 Eigen::Matrix<double, 2, 3>* jacobian_pose,
                                 Eigen::Matrix2d* jacobian_feature) {
  // Below this squared distance the bearing is undefined.
  constexpr double kMinSquaredRange = 1e-18;
  const Eigen::Vector2d delta = feature - pose.head<2>();
  const double q = delta.squaredNorm();
  if (!(q >= kMinSquaredRange)) return false;  // also rejects NaN
  const double range = std::sqrt(q);
  if (residual != nullptr) {
    (*residual)(0) = range - measurement(0);
    (*residual)(1) = WrapAngle(std::atan2(delta.y(), delta.x()) - pose.z() - measurement(1));
  }
  // Table 2 l.17 with the corrected rows (errata: docs/design.md).
  const double dx = delta.x(), dy = delta.y();
  if (jacobian_pose != nullptr) {
    *jacobian_pose << -dx / range, -dy / range, 0.0,  //
        dy / q, -dx / q, -1.0;
  }
  if (jacobian_feature != nullptr) {
    *jacobian_feature << dx / range, dy / range,  //
        -dy / q, dx / q;
  }
  return true;
}

// The feature position that would produce `measurement` from `pose`
// (initialization from first sight, Table 1):
//   m = (x, y) + r (cos(theta + phi), sin(theta + phi)).
Point2 InvertRangeBearing(const Pose2& pose, const Eigen::Vector2d& measurement);

// The model's entry in the registry (core/observation_models.h). A range of 0
// is rejected by the readers: the bearing and the polar Jacobian are undefined.
struct RangeBearingModel {
  static constexpr const char* kName = "range-bearing";
  static constexpr const char* kNativeLogTag = "RB";
  static constexpr int kMeasurementDim = 2;
  static constexpr const char* kMeasurementFields[2] = {"range", "bearing"};
  static constexpr const char* kMeasurementRule = "range > 0";
  static int InvalidMeasurementField(const Eigen::Vector2d& z) { return z(0) > 0.0 ? -1 : 0; }
  static bool Evaluate(const Pose2& pose, const Point2& feature, const Eigen::Vector2d& z,
                       Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 3>* jacobian_pose,
                       Eigen::Matrix2d* jacobian_feature) {
    return EvaluateRangeBearing(pose, feature, z, residual, jacobian_pose, jacobian_feature);
  }
  static Point2 Invert(const Pose2& pose, const Eigen::Vector2d& z) {
    return InvertRangeBearing(pose, z);
  }
};

}  // namespace graphslam::core
