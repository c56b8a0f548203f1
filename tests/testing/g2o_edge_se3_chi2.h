// chi2 of a 3-D pose graph as g2o's EdgeSE3 defines it, computed without the
// project's SE(3) code, so that a solve's reported chi2 can be checked
// against an independent formula:
//   E = Z^-1 Xi^-1 Xj  (4x4 homogeneous matrices),
//   e = [t(E); vec(q(E))] with q(E) from E's rotation, sign chosen so w >= 0,
//   chi2 = sum over edges of e' Omega e.
#pragma once

#include <Eigen/Geometry>

#include "core/problem_3d.h"

namespace graphslam::testing {

inline double G2oEdgeSe3Chi2(const core::Problem3d& p) {
  auto matrix = [](const core::Pose3& pose) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.topLeftCorner<3, 3>() = pose.q.toRotationMatrix();
    m.topRightCorner<3, 1>() = pose.t;
    return m;
  };
  double chi2 = 0.0;
  for (const auto& c : p.relative_poses) {
    const Eigen::Matrix4d e =
        matrix(c.z).inverse() * matrix(p.poses[c.from]).inverse() * matrix(p.poses[c.to]);
    Eigen::Quaterniond q(Eigen::Matrix3d(e.topLeftCorner<3, 3>()));
    if (q.w() < 0) q.coeffs() = -q.coeffs();
    Eigen::Matrix<double, 6, 1> r;
    r << e.topRightCorner<3, 1>(), q.vec();
    chi2 += r.dot(c.information * r);
  }
  return chi2;
}

}  // namespace graphslam::testing
