// A planar pose as one line of a KITTI odometry poses file (poses/NN.txt),
// for tests that write KITTI ground truth: the camera pose [R | t], 12
// numbers row first, camera axes x right, y down, z forward. With C the
// rotation from camera to body axes (x forward, y left, z up; body -> camera
// is C^T, storage/kitti_pose_reader.h):
//
//   R = C^T Rz(theta) C,   t = C^T (x, y, 0)
//
// so the reader's KittiCameraToBody gives back (x, y, theta).
#pragma once

#include <Eigen/Geometry>
#include <cstdio>
#include <string>

#include "core/se2.h"

namespace graphslam::testing {

inline std::string KittiPoseLine(const core::Pose2& p) {
  Eigen::Matrix3d c;
  c << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Matrix3d r =
      c.transpose() * Eigen::AngleAxisd(p.z(), Eigen::Vector3d::UnitZ()).toRotationMatrix() * c;
  const Eigen::Vector3d t = c.transpose() * Eigen::Vector3d(p.x(), p.y(), 0.0);
  char line[600];
  std::snprintf(line, sizeof(line),
                "%.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n",
                r(0, 0), r(0, 1), r(0, 2), t.x(), r(1, 0), r(1, 1), r(1, 2), t.y(), r(2, 0),
                r(2, 1), r(2, 2), t.z());
  return line;
}

}  // namespace graphslam::testing
