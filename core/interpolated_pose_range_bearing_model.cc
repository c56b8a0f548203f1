#include "core/interpolated_pose_range_bearing_model.h"

#include "core/range_bearing_model.h"

namespace graphslam::core {

Point2 InterpolatePosition(const Pose2& before, const Pose2& after, double alpha) {
  return (1.0 - alpha) * before.head<2>() + alpha * after.head<2>();
}

bool EvaluateInterpolatedPoseRangeBearing(const Pose2& observer, const Pose2& observed_before,
                                          const Pose2& observed_after, double alpha,
                                          const Eigen::Vector2d& measurement,
                                          Eigen::Vector2d* residual,
                                          Eigen::Matrix<double, 2, 3>* jacobian_observer,
                                          Eigen::Matrix<double, 2, 3>* jacobian_before,
                                          Eigen::Matrix<double, 2, 3>* jacobian_after) {
  const bool wants_point = jacobian_before != nullptr || jacobian_after != nullptr;
  Eigen::Matrix2d jacobian_point;
  if (!EvaluateRangeBearing(observer, InterpolatePosition(observed_before, observed_after, alpha),
                            measurement, residual, jacobian_observer,
                            wants_point ? &jacobian_point : nullptr)) {
    return false;
  }
  if (jacobian_before != nullptr) {
    jacobian_before->leftCols<2>() = (1.0 - alpha) * jacobian_point;
    jacobian_before->col(2).setZero();
  }
  if (jacobian_after != nullptr) {
    jacobian_after->leftCols<2>() = alpha * jacobian_point;
    jacobian_after->col(2).setZero();
  }
  return true;
}

}  // namespace graphslam::core
