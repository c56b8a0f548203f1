// A 3-D laser scan attached to a pose: points in the sensor frame and the
// sensor's pose in the world,
//
//   p_world = sensor_pose.q * p_sensor + sensor_pose.t      (core/se3.h)
//
// The sensor origin in the world (where OctoMap's rays start) is
// sensor_pose.t. Units are metres, frames right-handed (readers of other
// conventions, e.g. 3DTK's left-handed centimetres, convert on read).
//
// THREAD SAFETY: plain data. ALLOCATION: the point and intensity vectors.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/se3.h"

namespace graphslam::map {

struct Scan {
  int64_t pose = -1;  // index of the pose (trajectory row) the scan belongs to; -1: none
  int32_t run = -1;   // run id (which drive); -1: none
  core::Pose3 sensor_pose;               // sensor frame -> world
  std::vector<Eigen::Vector3f> points;   // sensor frame [m]
  std::vector<float> intensity;          // empty, or one per point

  bool has_intensity() const { return !intensity.empty(); }
};

// The scan's points in the world frame (float, as OctoMap stores them).
inline std::vector<Eigen::Vector3f> WorldPoints(const Scan& scan) {
  std::vector<Eigen::Vector3f> out;
  out.reserve(scan.points.size());
  const Eigen::Matrix3d r = scan.sensor_pose.rotation();
  for (const Eigen::Vector3f& p : scan.points) {
    out.push_back((r * p.cast<double>() + scan.sensor_pose.t).cast<float>());
  }
  return out;
}

}  // namespace graphslam::map
