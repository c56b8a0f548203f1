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
//     or from a position interpolated between two poses
//                                      (interpolated_pose_range_bearing_model.h)
// The unknowns and their ids, and the relative-pose and GPS constraints, are
// the dimension-free templates of core/problem_unknowns.h (as in Problem3d).
//
// THREAD SAFETY: a plain value. ALLOCATION: O(poses + features + constraints).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/observation_models.h"
#include "core/problem_unknowns.h"
#include "core/se2.h"
#include "core/velocity_motion_model.h"

namespace graphslam::core {

// A feature seen from a pose by one of the registry's models
// (core/problem_unknowns.h: ObservationOf; z and information 2-D, a 1-D
// model padded as core/observation_models.h says).
using Observation = ObservationOf<2, ObservationKind>;
static_assert(ObservationKind{} == ObservationKind::kRangeBearing);

// Pose `to` in the frame of pose `from` (core/relative_pose_model.h).
using RelativePoseConstraint = RelativePoseConstraintOf<Pose2, 3>;

struct VelocityMotionConstraint {
  int32_t from = -1;
  int32_t to = -1;
  VelocityControl control;
  Eigen::Matrix3d information = Eigen::Matrix3d::Identity();  // R_t^{-1}
  int32_t line = 0;
};

using GpsConstraint = GpsConstraintOf<2>;  // core/gps_model.h

// Pose `to`'s position (x, y) measured as (range, bearing) from pose `from`
// (core/pose_range_bearing_model.h): a robot seeing another robot. With
// to_next >= 0 the observed robot had no pose at the measurement's time, and
// its position is interpolated at alpha between poses `to` and `to_next`
// (core/interpolated_pose_range_bearing_model.h): a three-pose factor.
struct PoseRangeBearingConstraint {
  int32_t from = -1;  // observing pose
  int32_t to = -1;    // observed pose (with to_next >= 0: the one before)
  Eigen::Vector2d z = Eigen::Vector2d::Zero();  // range, bearing
  Eigen::Matrix2d information = Eigen::Matrix2d::Identity();
  int32_t line = 0;
  int32_t to_next = -1;  // -1: the observed pose is `to`; else the one after
  double alpha = 0.0;    // in [0, 1]: where between `to` and `to_next`

  bool interpolated() const { return to_next >= 0; }
};

struct Problem2d : ProblemUnknowns<Pose2, Point2> {
  std::vector<double> pose_stamps;  // seconds, or NaN when the input has no time

  std::vector<RelativePoseConstraint> relative_poses;
  std::vector<VelocityMotionConstraint> motions;
  std::vector<GpsConstraint> gps;
  std::vector<PoseRangeBearingConstraint> pose_range_bearings;
  std::vector<Observation> observations;

  // Appends a pose (and its time) and returns its index.
  int32_t AddPose(int64_t id, const Pose2& initial, bool initialized, int32_t line,
                  double stamp = std::numeric_limits<double>::quiet_NaN()) {
    pose_stamps.push_back(stamp);
    return ProblemUnknowns::AddPose(id, initial, initialized, line);
  }
};

}  // namespace graphslam::core
