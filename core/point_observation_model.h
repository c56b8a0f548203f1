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

// The model's entry in the registry (core/observation_models.h).
struct PointXYModel {
  static constexpr const char* kName = "point-xy";
  static constexpr const char* kNativeLogTag = "XY";
  static constexpr int kMeasurementDim = 2;
  static constexpr const char* kMeasurementFields[2] = {"x", "y"};
  static constexpr const char* kMeasurementRule = "finite x and y";
  static int InvalidMeasurementField(const Eigen::Vector2d&) { return -1; }
  static bool Evaluate(const Pose2& pose, const Point2& feature, const Eigen::Vector2d& z,
                       Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 3>* jacobian_pose,
                       Eigen::Matrix2d* jacobian_feature) {
    EvaluatePointObservation(pose, feature, z, residual, jacobian_pose, jacobian_feature);
    return true;
  }
  static Point2 Invert(const Pose2& pose, const Eigen::Vector2d& z) {
    return InvertPointObservation(pose, z);
  }
};

}  // namespace graphslam::core
