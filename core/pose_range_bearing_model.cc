#include "core/pose_range_bearing_model.h"

#include "core/range_bearing_model.h"

namespace graphslam::core {

bool EvaluatePoseRangeBearing(const Pose2& observer, const Pose2& observed,
                              const Eigen::Vector2d& measurement, Eigen::Vector2d* residual,
                              Eigen::Matrix<double, 2, 3>* jacobian_observer,
                              Eigen::Matrix<double, 2, 3>* jacobian_observed) {
  Eigen::Matrix2d jacobian_point;
  if (!EvaluateRangeBearing(observer, observed.head<2>(), measurement, residual,
                            jacobian_observer,
                            jacobian_observed != nullptr ? &jacobian_point : nullptr)) {
    return false;
  }
  if (jacobian_observed != nullptr) {
    jacobian_observed->leftCols<2>() = jacobian_point;
    jacobian_observed->col(2).setZero();
  }
  return true;
}

}  // namespace graphslam::core
