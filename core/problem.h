// Problem2d: every constraint of a planar full-SLAM problem, as read from the
// inputs, before partitioning into chunks.
//
// Unknowns: poses x_0..x_{T-1} (x, y, theta) and point features m_0..m_{N-1}.
// Constraints (each a Gaussian with an information matrix Omega, contributing
// e^T Omega e to chi2, the g2o convention):
//   - relative-pose odometry between two poses        (relative_pose_model.h)
//   - velocity motion between consecutive poses         (velocity_motion_model.h)
//   - GPS position fixes of a pose                      (gps_model.h)
//   - observations of a feature from a pose, one of the observation models
//     of the registry                                   (observation_models.h)
//   - range-bearing measurements of one pose's position from another pose
//     (a robot seeing another robot)                    (pose_range_bearing_model.h)
// Indices are dense (0..n-1); the ids of the input file are kept beside them so
// outputs reuse them. Pose and feature ids may share one number space (g2o).
//
// THREAD SAFETY: a plain value. ALLOCATION: O(poses + features + constraints).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "core/observation_models.h"
#include "core/se2.h"
#include "core/velocity_motion_model.h"

namespace graphslam::core {

struct Observation {
  int32_t pose = -1;     // index into Problem2d::poses
  int32_t feature = -1;  // index into Problem2d::features
  ObservationKind kind = ObservationKind::kRangeBearing;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d information = Eigen::Matrix2d::Identity();
  int32_t line = 0;  // 1-based line in the input, 0 if not from a text file
};

struct RelativePoseConstraint {
  int32_t from = -1;
  int32_t to = -1;
  Pose2 z = Pose2::Zero();  // pose `to` in the frame of pose `from`
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
  int32_t line = 0;
};

struct VelocityMotionConstraint {
  int32_t from = -1;
  int32_t to = -1;
  VelocityControl control;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();  // R_t^{-1}
  int32_t line = 0;
};

struct GpsConstraint {
  int32_t pose = -1;
  Eigen::Vector2d z = Eigen::Vector2d::Zero();
  Eigen::Matrix2d information = Eigen::Matrix2d::Identity();
  int32_t line = 0;
};

// Pose `to`'s position (x, y) measured as (range, bearing) from pose `from`
// (core/pose_range_bearing_model.h): a robot seeing another robot.
struct PoseRangeBearingConstraint {
  int32_t from = -1;  // observing pose
  int32_t to = -1;    // observed pose
  Eigen::Vector2d z = Eigen::Vector2d::Zero();  // range, bearing
  Eigen::Matrix2d information = Eigen::Matrix2d::Identity();
  int32_t line = 0;
};

struct Problem2d {
  std::string source;  // path of the input, for messages

  // Poses, in input order. pose_initialized[i] is 0 when the input gave no
  // initial guess (edges-only files): Initialize() chains odometry for those.
  std::vector<Pose2> poses;
  std::vector<int64_t> pose_ids;
  std::vector<uint8_t> pose_fixed;        // g2o FIX, or the anchor
  std::vector<uint8_t> pose_initialized;
  std::vector<int32_t> pose_lines;        // where each pose was defined (0 if implicit)
  std::vector<double> pose_stamps;        // seconds, or NaN when the input has no time

  std::vector<Point2> features;
  std::vector<int64_t> feature_ids;
  std::vector<uint8_t> feature_initialized;

  std::vector<RelativePoseConstraint> relative_poses;
  std::vector<VelocityMotionConstraint> motions;
  std::vector<GpsConstraint> gps;
  std::vector<PoseRangeBearingConstraint> pose_range_bearings;
  std::vector<Observation> observations;

  int32_t num_poses() const { return static_cast<int32_t>(poses.size()); }
  int32_t num_features() const { return static_cast<int32_t>(features.size()); }

  // Appends a pose and returns its index.
  int32_t AddPose(int64_t id, const Pose2& initial, bool initialized, int32_t line,
                  double stamp = std::numeric_limits<double>::quiet_NaN()) {
    poses.push_back(initial);
    pose_ids.push_back(id);
    pose_fixed.push_back(0);
    pose_initialized.push_back(initialized ? 1 : 0);
    pose_lines.push_back(line);
    pose_stamps.push_back(stamp);
    return num_poses() - 1;
  }
  // Appends a feature and returns its index.
  int32_t AddFeature(int64_t id, const Point2& initial, bool initialized) {
    features.push_back(initial);
    feature_ids.push_back(id);
    feature_initialized.push_back(initialized ? 1 : 0);
    return num_features() - 1;
  }
};

}  // namespace graphslam::core
