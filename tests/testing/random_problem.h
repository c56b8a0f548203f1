// Canned random planar SLAM problems with ground truth, for solver tests.
//
// A robot drives a noisy loop of `num_poses` poses around `num_features`
// landmarks scattered in a ring; it sees every landmark within `sensor_range`.
// Constraints: relative-pose odometry (or velocity motion), range-bearing or
// point observations, optional GPS. Measurements are ground truth plus noise
// drawn with the stated information, so chi2 at the optimum ~ dof.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>
#include <random>

#include "core/problem.h"
#include "core/se2.h"

namespace graphslam::testing {

struct RandomProblemOptions {
  int num_poses = 30;
  int num_features = 12;
  double sensor_range = 6.0;
  bool range_bearing = true;  // else point observations (EDGE_SE2_XY)
  bool velocity_motion = false;
  int gps_every = 0;          // 0: no GPS
  bool perturb_initial = true;
  uint32_t seed = 1;
};

struct RandomProblem {
  core::Problem2d problem;
  std::vector<core::Pose2> true_poses;
  std::vector<core::Point2> true_features;
};

inline RandomProblem MakeRandomProblem(const RandomProblemOptions& options) {
  std::mt19937 rng(options.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  RandomProblem out;
  core::Problem2d& p = out.problem;
  p.source = "random";
  const double radius = 5.0;
  for (int i = 0; i < options.num_poses; ++i) {
    const double a = 2.0 * std::numbers::pi * i / options.num_poses;
    out.true_poses.emplace_back(radius * std::cos(a), radius * std::sin(a),
                                core::WrapAngle(a + std::numbers::pi / 2));
  }
  for (int j = 0; j < options.num_features; ++j) {
    const double a = 2.0 * std::numbers::pi * uniform(rng);
    const double r = radius + (uniform(rng) < 0.5 ? -1.0 : 1.0) * (1.0 + 2.0 * uniform(rng));
    out.true_features.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  const double sigma_xy = 0.05, sigma_theta = 0.02, sigma_range = 0.1, sigma_bearing = 0.03;
  for (int i = 0; i < options.num_poses; ++i) {
    core::Pose2 guess = out.true_poses[i];
    if (options.perturb_initial && i > 0)
      guess += Eigen::Vector3d(0.3 * normal(rng), 0.3 * normal(rng), 0.1 * normal(rng));
    p.AddPose(i, guess, true, 0, static_cast<double>(i));
  }
  for (int j = 0; j < options.num_features; ++j) {
    core::Point2 guess = out.true_features[j];
    if (options.perturb_initial) guess += Eigen::Vector2d(0.3 * normal(rng), 0.3 * normal(rng));
    p.AddFeature(1000 + j, guess, true);
  }
  for (int i = 0; i + 1 < options.num_poses; ++i) {
    if (options.velocity_motion) {
      // Choose the control that moves exactly between the true poses (a
      // circle arc), then add noise to the result through the information.
      const core::Pose2 rel = core::Between(out.true_poses[i], out.true_poses[i + 1]);
      core::VelocityMotionConstraint c;
      c.from = i;
      c.to = i + 1;
      c.control.dt = 1.0;
      c.control.omega = rel.z();
      const double chord = rel.head<2>().norm();
      c.control.v = std::abs(rel.z()) > 1e-12 ? chord * rel.z() / (2.0 * std::sin(rel.z() / 2.0)) : chord;
      c.information = Eigen::Vector3d(1 / (sigma_xy * sigma_xy), 1 / (sigma_xy * sigma_xy),
                                      1 / (sigma_theta * sigma_theta)).asDiagonal();
      p.motions.push_back(c);
    } else {
      core::RelativePoseConstraint c;
      c.from = i;
      c.to = i + 1;
      c.z = core::Between(out.true_poses[i], out.true_poses[i + 1]);
      c.z += Eigen::Vector3d(sigma_xy * normal(rng), sigma_xy * normal(rng), sigma_theta * normal(rng));
      c.information = Eigen::Vector3d(1 / (sigma_xy * sigma_xy), 1 / (sigma_xy * sigma_xy),
                                      1 / (sigma_theta * sigma_theta)).asDiagonal();
      p.relative_poses.push_back(c);
    }
  }
  for (int i = 0; i < options.num_poses; ++i) {
    for (int j = 0; j < options.num_features; ++j) {
      const core::Pose2& x = out.true_poses[i];
      const Eigen::Vector2d delta = out.true_features[j] - x.head<2>();
      if (delta.norm() > options.sensor_range) continue;
      core::Observation o;
      o.pose = i;
      o.feature = j;
      if (options.range_bearing) {
        o.kind = core::ObservationKind::kRangeBearing;
        o.z = Eigen::Vector2d(delta.norm() + sigma_range * normal(rng),
                              core::WrapAngle(std::atan2(delta.y(), delta.x()) - x.z() +
                                              sigma_bearing * normal(rng)));
        o.information = Eigen::Vector2d(1 / (sigma_range * sigma_range),
                                        1 / (sigma_bearing * sigma_bearing)).asDiagonal();
      } else {
        o.kind = core::ObservationKind::kPointXY;
        o.z = core::Rotation2(x.z()).transpose() * delta +
              Eigen::Vector2d(sigma_range * normal(rng), sigma_range * normal(rng));
        o.information = Eigen::Matrix2d::Identity() / (sigma_range * sigma_range);
      }
      p.observations.push_back(o);
    }
  }
  if (options.gps_every > 0) {
    for (int i = 0; i < options.num_poses; i += options.gps_every) {
      core::GpsConstraint g;
      g.pose = i;
      g.z = out.true_poses[i].head<2>() + Eigen::Vector2d(0.5 * normal(rng), 0.5 * normal(rng));
      g.information = Eigen::Matrix2d::Identity() / 0.25;
      p.gps.push_back(g);
    }
  }
  return out;
}

// The small point-landmark world of the association tests: 40 poses, 10
// landmarks seen as points within 4 m.
inline RandomProblem MakeSmallPointWorld(uint32_t seed) {
  RandomProblemOptions options;
  options.num_poses = 40;
  options.num_features = 10;
  options.range_bearing = false;
  options.sensor_range = 4.0;
  options.seed = seed;
  return MakeRandomProblem(options);
}

}  // namespace graphslam::testing
