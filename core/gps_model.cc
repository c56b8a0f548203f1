#include "core/gps_model.h"

namespace graphslam::core {

void EvaluateGps(const Pose2& pose, const Eigen::Vector2d& measurement, Eigen::Vector2d* residual,
                 Eigen::Matrix<double, 2, 3>* jacobian_pose) {
  if (residual != nullptr) *residual = pose.head<2>() - measurement;
  if (jacobian_pose != nullptr) {
    jacobian_pose->setZero();
    (*jacobian_pose)(0, 0) = 1.0;
    (*jacobian_pose)(1, 1) = 1.0;
  }
}

}  // namespace graphslam::core
