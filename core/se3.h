// Rigid transforms in 3-D (SE(3)) as a unit quaternion and a translation.
//
//   T = (q, t):  x_world = q * x_local + t
//   Compose(a, b)  = (a.q b.q, a.q b.t + a.t)
//   Inverse(a)     = (a.q^-1, -(a.q^-1 a.t))
//   Between(a, b)  = Inverse(a) Compose b      (b expressed in a's frame)
// The g2o VERTEX_SE3:QUAT / EDGE_SE3:QUAT convention: x y z qx qy qz qw, with
// the measurement of an edge i->j being Between(x_i, x_j).
//
// The solver increments a pose on the tangent space in the body frame (see
// RetractPose3 below): x (+) delta = Compose(x, Exp(delta)), delta = (rho, phi)
// with rho the translation part and phi the rotation vector (so the 6-vector
// reads translation first, as g2o's and GTSAM's Pose3 do).
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace graphslam::core {

using Point3 = Eigen::Vector3d;
using Vector6d = Eigen::Matrix<double, 6, 1>;

struct Pose3 {
  Eigen::Quaterniond q = Eigen::Quaterniond::Identity();  // unit norm
  Eigen::Vector3d t = Eigen::Vector3d::Zero();

  static Pose3 Identity() { return Pose3{}; }
  Eigen::Matrix3d rotation() const { return q.toRotationMatrix(); }
  Eigen::Isometry3d ToIsometry() const {
    Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
    iso.linear() = rotation();
    iso.translation() = t;
    return iso;
  }
};

inline Pose3 Compose(const Pose3& a, const Pose3& b) {
  Pose3 out;
  out.q = (a.q * b.q).normalized();
  out.t = a.q * b.t + a.t;
  return out;
}

inline Pose3 Inverse(const Pose3& a) {
  Pose3 out;
  out.q = a.q.conjugate();
  out.t = -(out.q * a.t);
  return out;
}

inline Pose3 Between(const Pose3& a, const Pose3& b) {
  Pose3 out;
  const Eigen::Quaterniond qa_inv = a.q.conjugate();
  out.q = (qa_inv * b.q).normalized();
  out.t = qa_inv * (b.t - a.t);
  return out;
}

// A point from the frame of `pose` into the world frame.
inline Point3 TransformPoint(const Pose3& pose, const Point3& local) { return pose.q * local + pose.t; }
// A world point into the frame of `pose`.
inline Point3 InverseTransformPoint(const Pose3& pose, const Point3& world) {
  return pose.q.conjugate() * (world - pose.t);
}

}  // namespace graphslam::core
