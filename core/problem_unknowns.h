// The parts of a full-SLAM problem that do not depend on the dimension,
// written once over the pose and point types and used by Problem2d
// (core/problem.h: SE(2) poses, R^2 features) and Problem3d
// (core/problem_3d.h: SE(3) poses, R^3 features):
//   - ProblemUnknowns: the unknowns, poses x_0..x_{T-1} and features
//     m_0..m_{N-1}, with their input ids and flags;
//   - RelativePoseConstraintOf: pose `to` measured in the frame of pose
//     `from`, information on the model's residual (kDof x kDof);
//   - GpsConstraintOf: a pose's position measured in the world frame;
//   - ObservationOf: a feature measured from a pose, z in R^kDim with its
//     information (kDim x kDim), and the model's kind where the space has
//     several (2-D: core/observation_models.h; 3-D has one, OneModel).
// Indices are dense (0..n-1); the ids of the input file are kept beside them
// so outputs reuse them. Pose and feature ids may share one number space (g2o).
//
// THREAD SAFETY: plain values. ALLOCATION: O(poses + features).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <type_traits>
#include <vector>

namespace graphslam::core {

// The identity of a pose type: the zero vector for planar (x, y, theta),
// Pose::Identity() for SE(3).
template <class Pose>
Pose IdentityPose() {
  if constexpr (std::is_base_of_v<Eigen::MatrixBase<Pose>, Pose>) {
    return Pose::Zero();
  } else {
    return Pose::Identity();
  }
}

template <class PoseT, int kDof>
struct RelativePoseConstraintOf {
  int32_t from = -1;
  int32_t to = -1;
  PoseT z = IdentityPose<PoseT>();  // pose `to` in the frame of pose `from`
  Eigen::Matrix<double, kDof, kDof> information = Eigen::Matrix<double, kDof, kDof>::Identity();
  int32_t line = 0;  // 1-based line in the input, 0 if not from a text file
};

template <int kDim>
struct GpsConstraintOf {
  int32_t pose = -1;
  Eigen::Matrix<double, kDim, 1> z = Eigen::Matrix<double, kDim, 1>::Zero();
  Eigen::Matrix<double, kDim, kDim> information = Eigen::Matrix<double, kDim, kDim>::Identity();
  int32_t line = 0;
};

// The kind of a space with a single observation model: nothing stored
// ([[no_unique_address]] below: the record keeps the size it had without it).
struct OneModel {
  friend bool operator==(OneModel, OneModel) { return true; }
};

template <int kDim, class Kind>
struct ObservationOf {
  int32_t pose = -1;     // index into the problem's poses
  int32_t feature = -1;  // index into the problem's features
  [[no_unique_address]] Kind kind{};  // 2-D: kRangeBearing (0) unless set
  Eigen::Matrix<double, kDim, 1> z = Eigen::Matrix<double, kDim, 1>::Zero();
  Eigen::Matrix<double, kDim, kDim> information = Eigen::Matrix<double, kDim, kDim>::Identity();
  int32_t line = 0;  // 1-based line in the input, 0 if not from a text file
};

template <class PoseT, class PointT>
struct ProblemUnknowns {
  using Pose = PoseT;
  using Point = PointT;

  std::string source;  // path of the input, for messages

  // Poses, in input order. pose_initialized[i] is 0 when the input gave no
  // initial guess (edges-only files): the initializer chains odometry for those.
  std::vector<Pose> poses;
  std::vector<int64_t> pose_ids;
  std::vector<uint8_t> pose_fixed;        // g2o FIX, or the anchor
  std::vector<uint8_t> pose_initialized;
  std::vector<int32_t> pose_lines;        // where each pose was defined (0 if implicit)

  std::vector<Point> features;
  std::vector<int64_t> feature_ids;
  std::vector<uint8_t> feature_initialized;

  int32_t num_poses() const { return static_cast<int32_t>(poses.size()); }
  int32_t num_features() const { return static_cast<int32_t>(features.size()); }

  // Appends a pose and returns its index.
  int32_t AddPose(int64_t id, const Pose& initial, bool initialized, int32_t line) {
    poses.push_back(initial);
    pose_ids.push_back(id);
    pose_fixed.push_back(0);
    pose_initialized.push_back(initialized ? 1 : 0);
    pose_lines.push_back(line);
    return num_poses() - 1;
  }
  // Appends a feature and returns its index.
  int32_t AddFeature(int64_t id, const Point& initial, bool initialized) {
    features.push_back(initial);
    feature_ids.push_back(id);
    feature_initialized.push_back(initialized ? 1 : 0);
    return num_features() - 1;
  }
};

}  // namespace graphslam::core
