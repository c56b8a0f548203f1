// Random pose-feature pairs for the planar measurement models' Jacobian tests,
// biased to where angle handling breaks: draw i of every four has the heading
// near +-pi, the feature behind the robot, the world angle at atan2's jump, or
// nothing special.
#pragma once

#include <Eigen/Core>
#include <cmath>
#include <numbers>
#include <random>

#include "core/se2.h"

namespace graphslam::testing {

struct PlanarDraw {
  core::Pose2 pose;
  core::Point2 feature;
  double world_angle = 0.0;  // direction from the robot to the feature
};

// Draw `i` (0-based) with `rng`: positions in [-20, 20], ranges in [0.2, 30].
inline PlanarDraw DrawAcrossPi(int i, std::mt19937& rng) {
  constexpr double kPi = std::numbers::pi;
  std::uniform_real_distribution<double> position(-20.0, 20.0), angle(-kPi, kPi), range(0.2, 30.0),
      small(-0.05, 0.05);
  PlanarDraw draw;
  draw.pose = core::Pose2(position(rng), position(rng), angle(rng));
  draw.world_angle = angle(rng);
  if (i % 4 == 0) draw.pose.z() = (i % 8 == 0 ? kPi : -kPi) + small(rng) * 1e-3;  // theta near +-pi
  if (i % 4 == 1) draw.world_angle = draw.pose.z() + kPi + small(rng) * 1e-3;     // feature behind
  if (i % 4 == 2) draw.world_angle = kPi + small(rng) * 1e-3;                     // atan2 jumps
  draw.feature = draw.pose.head<2>() +
                 range(rng) * Eigen::Vector2d(std::cos(draw.world_angle), std::sin(draw.world_angle));
  return draw;
}

}  // namespace graphslam::testing
