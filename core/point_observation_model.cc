#include "core/point_observation_model.h"

#include <cmath>

namespace graphslam::core {

void EvaluatePointObservation(const Pose2& pose, const Point2& feature,
                              const Eigen::Vector2d& measurement, Eigen::Vector2d* residual,
                              Eigen::Matrix<double, 2, 3>* jacobian_pose,
                              Eigen::Matrix2d* jacobian_feature) {
  const Eigen::Matrix2d rotation_t = Rotation2(pose.z()).transpose();
  const Eigen::Vector2d delta = feature - pose.head<2>();
  if (residual != nullptr) *residual = rotation_t * delta - measurement;
  if (jacobian_pose != nullptr) {
    // dR^T/dtheta = [-s c; -c -s].
    const double c = std::cos(pose.z()), s = std::sin(pose.z());
    Eigen::Matrix2d rotation_t_derivative;
    rotation_t_derivative << -s, c, -c, -s;
    jacobian_pose->block<2, 2>(0, 0) = -rotation_t;
    jacobian_pose->col(2) = rotation_t_derivative * delta;
  }
  if (jacobian_feature != nullptr) *jacobian_feature = rotation_t;
}

Point2 InvertPointObservation(const Pose2& pose, const Eigen::Vector2d& measurement) {
  return TransformPoint(pose, measurement);
}

}  // namespace graphslam::core
