// The two problem spaces of the GraphSLAM solve, as compile-time traits: the
// chunk passes (core/chunk_passes.h), the feature linearizer and the solver
// loop are written once as templates on a Space and instantiated for these
// two in their .cc files (fixed block sizes in the hot loops).
//
//   Space2d: poses SE(2) (x, y, theta), pose block kPoseDim = 3; features
//            R^2, kFeatureDim = 2; Observation (any model of the registry,
//            core/observation_models.h).
//   Space3d: poses SE(3) (unit quaternion, translation), kPoseDim = 6;
//            features R^3, kFeatureDim = 3; Point3Observation (a point in
//            the frame of the pose).
//
// Each Space gives the observation's residual and Jacobians
//   e = h(x, m) - z,   J_x = de/dd (kFeatureDim x kPoseDim),   J_m = de/dm,
// where d is the body-frame increment of the pose retraction x (+) d
// (core/se2.h: Compose(x, d); core/se3_lie.h: x Exp(d)), and m (+) dm = m + dm.
// The planar models are differentiated w.r.t. (x, y, theta) and carried to the
// increment by RetractionJacobian(x) here, after evaluation, as the planar
// linearizer always did (the same floating-point operations).
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <vector>

#include "core/observation_models.h"
#include "core/point_3d_observation_model.h"
#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/se2.h"
#include "core/se3_lie.h"

namespace graphslam::core {

struct Space2d {
  static constexpr int kPoseDim = 3;
  static constexpr int kFeatureDim = 2;
  static constexpr const char* kName = "";  // log prefix of the solver
  using Pose = Pose2;
  using Point = Point2;
  using Observation = core::Observation;
  using Problem = Problem2d;
  using PoseVector = Eigen::Matrix<double, kPoseDim, 1>;

  // What the pose Jacobian of every observation from a pose shares: the
  // rotation of RetractionJacobian(pose), (cos theta, sin theta). A pass
  // computes it once per pose (PoseFrames) instead of once per observation.
  using PoseFrame = Eigen::Vector2d;
  static PoseFrame Frame(const Pose& pose) {
    return PoseFrame(std::cos(pose.z()), std::sin(pose.z()));
  }

  // Residual and Jacobians (any of them may be nullptr); false if the
  // observation is degenerate (e.g. range-bearing with the feature on the robot).
  static bool Evaluate(const Observation& observation, const Pose& pose, const Point& feature,
                       Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 3>* jacobian_pose,
                       Eigen::Matrix2d* jacobian_feature) {
    const bool ok = EvaluateObservation(observation.kind, pose, feature, observation.z, residual,
                                        jacobian_pose, jacobian_feature);
    if (ok && jacobian_pose != nullptr) *jacobian_pose = *jacobian_pose * RetractionJacobian(pose);
    return ok;
  }
  // The same with the pose's frame given (Frame(pose)); the same bits.
  static bool Evaluate(const Observation& observation, const Pose& pose, const PoseFrame& frame,
                       const Point& feature, Eigen::Vector2d* residual,
                       Eigen::Matrix<double, 2, 3>* jacobian_pose,
                       Eigen::Matrix2d* jacobian_feature) {
    const bool ok = EvaluateObservation(observation.kind, pose, feature, observation.z, residual,
                                        jacobian_pose, jacobian_feature);
    if (ok && jacobian_pose != nullptr) {
      // RetractionJacobian(pose), from the frame's cos and sin.
      Eigen::Matrix3d retraction = Eigen::Matrix3d::Identity();
      retraction(0, 0) = frame(0);
      retraction(0, 1) = -frame(1);
      retraction(1, 0) = frame(1);
      retraction(1, 1) = frame(0);
      *jacobian_pose = *jacobian_pose * retraction;
    }
    return ok;
  }
  static Pose Retract(const Pose& pose, const PoseVector& delta) {
    return RetractPose(pose, delta);
  }
  // |x|^2 for the parameter tolerance (Ceres: the parameter vector's norm).
  static double StateSquaredNorm(const Pose& pose) { return pose.squaredNorm(); }
};

struct Space3d {
  static constexpr int kPoseDim = 6;
  static constexpr int kFeatureDim = 3;
  static constexpr const char* kName = "3-D ";
  using Pose = Pose3;
  using Point = Point3;
  using Observation = Point3Observation;
  using Problem = Problem3d;
  using PoseVector = Eigen::Matrix<double, kPoseDim, 1>;

  // Nothing is shared between a pose's observations beyond the pose itself.
  struct PoseFrame {};
  static PoseFrame Frame(const Pose&) { return {}; }

  static bool Evaluate(const Observation& observation, const Pose& pose, const Point& feature,
                       Eigen::Vector3d* residual, Eigen::Matrix<double, 3, 6>* jacobian_pose,
                       Eigen::Matrix3d* jacobian_feature) {
    EvaluatePoint3Observation(pose, feature, observation.z, residual, jacobian_pose,
                              jacobian_feature);
    return true;
  }
  static bool Evaluate(const Observation& observation, const Pose& pose, const PoseFrame&,
                       const Point& feature, Eigen::Vector3d* residual,
                       Eigen::Matrix<double, 3, 6>* jacobian_pose,
                       Eigen::Matrix3d* jacobian_feature) {
    return Evaluate(observation, pose, feature, residual, jacobian_pose, jacobian_feature);
  }
  static Pose Retract(const Pose& pose, const PoseVector& delta) {
    return RetractPose3(pose, delta);
  }
  // The pose's tangent coordinates, |Log(x)|^2.
  static double StateSquaredNorm(const Pose& pose) { return LogSE3(pose).squaredNorm(); }
};

// Space::Frame of every pose, computed once per pass (a few bytes per pose).
template <class Space>
std::vector<typename Space::PoseFrame> PoseFrames(const std::vector<typename Space::Pose>& poses) {
  std::vector<typename Space::PoseFrame> frames;
  frames.reserve(poses.size());
  for (const typename Space::Pose& pose : poses) frames.push_back(Space::Frame(pose));
  return frames;
}

}  // namespace graphslam::core
