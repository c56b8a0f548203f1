#include "core/range_bearing_model.h"

#include <cmath>

namespace graphslam::core {
namespace {
// Below this squared distance the bearing is undefined (header contract).
constexpr double kMinSquaredRange = 1e-18;
}  // namespace

bool EvaluateRangeBearing(const Pose2& pose, const Point2& feature,
                          const Eigen::Vector2d& measurement, Eigen::Vector2d* residual,
                          Eigen::Matrix<double, 2, 3>* jacobian_pose,
                          Eigen::Matrix2d* jacobian_feature) {
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

Point2 InvertRangeBearing(const Pose2& pose, const Eigen::Vector2d& measurement) {
  const double angle = pose.z() + measurement(1);
  return pose.head<2>() + measurement(0) * Eigen::Vector2d(std::cos(angle), std::sin(angle));
}

}  // namespace graphslam::core
