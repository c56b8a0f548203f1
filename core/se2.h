// Planar rigid transforms (SE(2)) as vectors (x, y, theta).
//
//   Compose(a, b)  = a (+) b = (R(a.t) b.xy + a.xy, wrap(a.t + b.t))
//   Inverse(a)     = (-R(a.t)^T a.xy, -a.t)
//   Between(a, b)  = Inverse(a) (+) b   (b expressed in a's frame)
// These are the t2v/v2t operations of g2o's EDGE_SE2.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "core/angle.h"

namespace graphslam::core {

using Pose2 = Eigen::Vector3d;   // (x, y, theta)
using Point2 = Eigen::Vector2d;  // (x, y)

inline Eigen::Matrix2d Rotation2(double theta) {
  const double c = std::cos(theta), s = std::sin(theta);
  Eigen::Matrix2d r;
  r << c, -s, s, c;
  return r;
}

inline Pose2 Compose(const Pose2& a, const Pose2& b) {
  Pose2 out;
  out.head<2>() = Rotation2(a.z()) * b.head<2>() + a.head<2>();
  out.z() = WrapAngle(a.z() + b.z());
  return out;
}

inline Pose2 Inverse(const Pose2& a) {
  Pose2 out;
  out.head<2>() = -(Rotation2(a.z()).transpose() * a.head<2>());
  out.z() = WrapAngle(-a.z());
  return out;
}

inline Pose2 Between(const Pose2& a, const Pose2& b) {
  Pose2 out;
  out.head<2>() = Rotation2(a.z()).transpose() * (b.head<2>() - a.head<2>());
  out.z() = WrapAngle(b.z() - a.z());
  return out;
}

// Transforms a point from the frame of `pose` into the world frame.
inline Point2 TransformPoint(const Pose2& pose, const Point2& local) {
  return Rotation2(pose.z()) * local + pose.head<2>();
}

// The pose increment of the solver: a body-frame step, g2o's SE2 oplus,
//   x (+) delta = Compose(x, delta).
// Jacobians of the models are taken w.r.t. delta at delta = 0:
//   d(x (+) delta)/d delta = [R(theta) 0; 0 1] = RetractionJacobian(x),
// so J_delta = J_xytheta * RetractionJacobian(x). Stepping in the body frame
// follows the same path through the cost as g2o and is the same algebra the
// SE(3) tangent-space increments use.
inline Pose2 RetractPose(const Pose2& x, const Eigen::Vector3d& delta) { return Compose(x, delta); }

inline Eigen::Matrix3d RetractionJacobian(const Pose2& x) {
  Eigen::Matrix3d m = Eigen::Matrix3d::Identity();
  m.topLeftCorner<2, 2>() = Rotation2(x.z());
  return m;
}

}  // namespace graphslam::core
