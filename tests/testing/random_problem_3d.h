// Canned random 3-D SLAM problems with ground truth, for solver tests.
//
// A loop of `n` SE(3) poses on a helix with odometry and two loop closures,
// `m` 3-D points each observed `observations_per_feature` times (in the pose
// frame) from poses spread along the loop, optional GPS on every pose.
// Measurements are the truth plus noise; the initial guess is perturbed
// (pose 0 exact). *true_points and *true_poses (optional) receive the truth.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <random>
#include <vector>

#include "core/problem_3d.h"
#include "core/se3_lie.h"

namespace graphslam::testing {

inline core::Vector6d Noise6(std::mt19937& rng, double sigma_t, double sigma_r) {
  std::normal_distribution<double> n(0.0, 1.0);
  core::Vector6d d;
  for (int i = 0; i < 3; ++i) d[i] = sigma_t * n(rng);
  for (int i = 3; i < 6; ++i) d[i] = sigma_r * n(rng);
  return d;
}

// A loop of `n` poses on a helix with loop closures, `m` points observed from
// nearby poses, optional GPS on every pose; initial guess perturbed.
// *true_points and *true_poses (optional) receive the noise-free state.
inline core::Problem3d MakeRandomProblem3d(int n, int m, bool gps, uint32_t seed,
                                           std::vector<core::Point3>* true_points = nullptr,
                                           std::vector<core::Pose3>* true_poses = nullptr,
                                           int observations_per_feature = 3) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::vector<core::Pose3> truth(n);
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * M_PI * i / n;
    truth[i].t = Eigen::Vector3d(4 * std::cos(a), 4 * std::sin(a), 0.3 * i);
    truth[i].q = core::ExpSO3(Eigen::Vector3d(0.1 * std::sin(a), 0.2, a + 0.5));
  }
  if (true_poses != nullptr) *true_poses = truth;
  core::Problem3d p;
  p.source = "random.g2o";
  for (int i = 0; i < n; ++i)
    p.AddPose(i, core::RetractPose3(truth[i], Noise6(rng, 0.3, 0.1)), true, 0);
  p.poses[0] = truth[0];
  core::Matrix6d info = core::Matrix6d::Identity();
  info.topLeftCorner<3, 3>() *= 50.0;
  info.bottomRightCorner<3, 3>() *= 400.0;
  info(0, 4) = info(4, 0) = 2.0;  // some correlation
  auto add_edge = [&](int i, int j) {
    core::RelativePose3Constraint c;
    c.from = i;
    c.to = j;
    c.z = core::RetractPose3(core::Between(truth[i], truth[j]), Noise6(rng, 0.05, 0.02));
    c.information = info;
    p.relative_poses.push_back(c);
  };
  for (int i = 0; i + 1 < n; ++i) add_edge(i, i + 1);
  add_edge(n - 1, 0);
  add_edge(2, n / 2);
  for (int f = 0; f < m; ++f) {
    const core::Point3 point(5 * normal(rng), 5 * normal(rng), 2 * normal(rng));
    if (true_points != nullptr) true_points->push_back(point);
    p.AddFeature(100 + f, point + Eigen::Vector3d(0.3, -0.2, 0.1), true);
    for (int k = 0; k < observations_per_feature; ++k) {
      core::Point3Observation o;
      o.pose = (f * 3 + k * 2) % n;
      o.feature = f;
      o.z = core::InverseTransformPoint(truth[o.pose], point) +
            0.02 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      o.information = Eigen::Matrix3d::Identity() * 100.0;
      o.information(0, 1) = o.information(1, 0) = 10.0;
      p.observations.push_back(o);
    }
  }
  if (gps) {
    for (int i = 0; i < n; ++i) {
      core::Gps3Constraint g;
      g.pose = i;
      g.z = truth[i].t + 0.1 * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
      g.information = Eigen::Matrix3d::Identity() * 10.0;
      p.gps.push_back(g);
    }
  }
  return p;
}

}  // namespace graphslam::testing
