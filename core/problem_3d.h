// Problem3d: every constraint of a 3-D full-SLAM problem, as read from the
// inputs (the 3-D counterpart of Problem2d, core/problem.h).
//
// Unknowns: poses x_0..x_{T-1} in SE(3) (core/se3.h) and point features
// m_0..m_{N-1} in R^3. Constraints (Gaussian, information Omega, each adding
// e^T Omega e to chi2, the g2o convention):
//   - relative pose between two poses      (relative_pose_3d_model.h)
//   - a point in the frame of a pose       (point_3d_observation_model.h)
//   - GPS position of a pose               (gps_3d_model.h)
// The unknowns and their ids, and the relative-pose and GPS constraints, are
// the dimension-free templates of core/problem_unknowns.h (as in Problem2d).
//
// THREAD SAFETY: a plain value. ALLOCATION: O(poses + features + constraints).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/problem_unknowns.h"
#include "core/se3_lie.h"

namespace graphslam::core {

// Information on e = [t; vec(q)] (g2o), core/relative_pose_3d_model.h.
using RelativePose3Constraint = RelativePoseConstraintOf<Pose3, 6>;

// The feature in the pose frame (core/point_3d_observation_model.h), the one
// 3-D model (core/problem_unknowns.h: ObservationOf).
using Point3Observation = ObservationOf<3, OneModel>;

using Gps3Constraint = GpsConstraintOf<3>;  // core/gps_3d_model.h

struct Problem3d : ProblemUnknowns<Pose3, Point3> {
  std::vector<RelativePose3Constraint> relative_poses;
  std::vector<Point3Observation> observations;
  std::vector<Gps3Constraint> gps;
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
