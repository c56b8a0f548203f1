// Problem3d: every constraint of a 3-D full-SLAM problem, as read from the
// inputs (the 3-D counterpart of Problem2d, core/problem.h).
//
// Unknowns: poses x_0..x_{T-1} in SE(3) (core/se3.h) and point features
// m_0..m_{N-1} in R^3. Constraints (Gaussian, information Omega, each adding
// e^T Omega e to chi2, the g2o convention):
//   - relative pose between two poses      (relative_pose3_model.h)
//   - a point in the frame of a pose       (point3_observation_model.h)
//   - GPS position of a pose               (gps3_model.h)
// Indices are dense (0..n-1); input ids are kept beside them for outputs.
//
// THREAD SAFETY: a plain value. ALLOCATION: O(poses + features + constraints).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "core/se3_lie.h"

namespace graphslam::core {

struct RelativePose3Constraint {
  int32_t from = -1;
  int32_t to = -1;
  Pose3 z;  // pose `to` in the frame of pose `from`
  Matrix6d information = Matrix6d::Identity();  // on e = [t; vec(q)] (g2o)
  int32_t line = 0;
};

struct Point3Observation {
  int32_t pose = -1;
  int32_t feature = -1;
  Eigen::Vector3d z = Eigen::Vector3d::Zero();  // feature in the pose frame
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  int32_t line = 0;
};

struct Gps3Constraint {
  int32_t pose = -1;
  Eigen::Vector3d z = Eigen::Vector3d::Zero();
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  int32_t line = 0;
};

struct Problem3d {
  std::string source;

  std::vector<Pose3> poses;
  std::vector<int64_t> pose_ids;
  std::vector<uint8_t> pose_fixed;
  std::vector<uint8_t> pose_initialized;  // 0: no guess in the input (chain odometry)
  std::vector<int32_t> pose_lines;

  std::vector<Point3> features;
  std::vector<int64_t> feature_ids;
  std::vector<uint8_t> feature_initialized;

  std::vector<RelativePose3Constraint> relative_poses;
  std::vector<Point3Observation> observations;
  std::vector<Gps3Constraint> gps;

  int32_t num_poses() const { return static_cast<int32_t>(poses.size()); }
  int32_t num_features() const { return static_cast<int32_t>(features.size()); }

  int32_t AddPose(int64_t id, const Pose3& initial, bool initialized, int32_t line) {
    poses.push_back(initial);
    pose_ids.push_back(id);
    pose_fixed.push_back(0);
    pose_initialized.push_back(initialized ? 1 : 0);
    pose_lines.push_back(line);
    return num_poses() - 1;
  }
  int32_t AddFeature(int64_t id, const Point3& initial, bool initialized) {
    features.push_back(initial);
    feature_ids.push_back(id);
    feature_initialized.push_back(initialized ? 1 : 0);
    return num_features() - 1;
  }
};

// The optimized poses of a 3-D solve, by input id: the hand-over to consumers
// that only need the trajectory (e.g. map building from scans).
struct OptimizedPoses3d {
  std::vector<int64_t> ids;
  std::vector<Pose3> poses;  // poses[k] belongs to ids[k]
};

inline OptimizedPoses3d ExtractOptimizedPoses(const Problem3d& problem) {
  OptimizedPoses3d out;
  out.ids = problem.pose_ids;
  out.poses = problem.poses;
  return out;
}

}  // namespace graphslam::core
