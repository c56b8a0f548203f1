// A time-stamped 3-D pose as trajectory files (TUM, KITTI odometry) hold it,
// and its projection onto the plane for the 2-D solver.
//
// Planar projection of a pose (p, q): x = p.x, y = p.y, and theta the yaw of
// q in the z-y-x (yaw-pitch-roll) convention,
//   theta = atan2(2 (qw qz + qx qy), 1 - 2 (qy^2 + qz^2)),
// so a pose that is a pure rotation about z keeps its angle exactly; z, roll
// and pitch are dropped.
//
// THREAD SAFETY: plain values. ALLOCATION: none.
#pragma once

#include <Eigen/Geometry>
#include <cmath>

#include "core/se2.h"

namespace graphslam::storage {

struct StampedPose3 {
  double stamp = 0.0;  // s (or the frame index, see the reader)
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // unit
};

inline core::Pose2 ProjectToPlane(const StampedPose3& pose) {
  const Eigen::Quaterniond& q = pose.orientation;
  const double yaw = std::atan2(2.0 * (q.w() * q.z() + q.x() * q.y()),
                                1.0 - 2.0 * (q.y() * q.y() + q.z() * q.z()));
  return core::Pose2(pose.position.x(), pose.position.y(), yaw);
}

}  // namespace graphslam::storage
