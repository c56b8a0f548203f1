// A random planar problem far from the quadratic regime, for tests of the
// trust region and of the fused chunk pass: tests/testing/random_problem.h's
// 40-pose, 15-feature loop with every heading but the first pose's moved by
// a uniform draw in [-2.5, 2.5] rad, so that the first full steps overshoot
// (some rejected, some accepted with a modest rho); optionally every
// feature's guess moved too. And the bit-for-bit comparison of two estimates
// that such tests make between two solver paths.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <random>

#include "core/problem.h"
#include "tests/testing/random_problem.h"

namespace graphslam::testing {

struct HeadingPerturbation {
  uint32_t seed = 1;
  int gps_every = 0;              // 0: no GPS
  double feature_offset_m = 0.0;  // features moved by up to this on each axis
};

inline core::Problem2d HeadingPerturbedProblem(const HeadingPerturbation& perturbation) {
  RandomProblemOptions options;
  options.num_poses = 40;
  options.num_features = 15;
  options.seed = perturbation.seed;
  options.gps_every = perturbation.gps_every;
  core::Problem2d problem = MakeRandomProblem(options).problem;
  std::mt19937 rng(perturbation.seed);
  std::uniform_real_distribution<double> heading(-2.5, 2.5);
  for (int p = 1; p < problem.num_poses(); ++p) problem.poses[p].z() += heading(rng);
  if (perturbation.feature_offset_m > 0.0) {
    std::uniform_real_distribution<double> offset(-perturbation.feature_offset_m,
                                                  perturbation.feature_offset_m);
    for (core::Point2& feature : problem.features)
      feature += core::Point2(offset(rng), offset(rng));
  }
  return problem;
}

// Every pose and feature of `a` equals `b`'s exactly.
inline void ExpectBitIdenticalEstimates(const core::Problem2d& a, const core::Problem2d& b) {
  ASSERT_EQ(a.num_poses(), b.num_poses());
  ASSERT_EQ(a.num_features(), b.num_features());
  for (int p = 0; p < a.num_poses(); ++p)
    EXPECT_EQ((a.poses[p] - b.poses[p]).norm(), 0.0) << "pose " << p;
  for (int j = 0; j < a.num_features(); ++j)
    EXPECT_EQ((a.features[j] - b.features[j]).norm(), 0.0) << "feature " << j;
}

}  // namespace graphslam::testing
