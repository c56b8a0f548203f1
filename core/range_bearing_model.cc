#include "core/range_bearing_model.h"

#include <cmath>

namespace graphslam::core {

Point2 InvertRangeBearing(const Pose2& pose, const Eigen::Vector2d& measurement) {
  const double angle = pose.z() + measurement(1);
  return pose.head<2>() + measurement(0) * Eigen::Vector2d(std::cos(angle), std::sin(angle));
}

}  // namespace graphslam::core
