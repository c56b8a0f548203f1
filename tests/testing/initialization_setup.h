// The setup the initialization tests share (incremental and progressive
// initialization): a random loop with a much worse initial guess than the
// default perturbation, its dense optimum, and the full in-memory solve that
// follows an initialization.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <random>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/dense_reference.h"
#include "tests/testing/random_problem.h"

namespace graphslam::testing {

// The random loop of MakeRandomProblem (num_poses poses, 14 features) with
// every pose but the anchor moved by N(0, diag(1, 1, 0.6^2)) and every
// feature by N(0, 2^2 I), drawn from seed + 100.
inline RandomProblem BadlyInitializedProblem(uint32_t seed, int num_poses, bool range_bearing,
                                             bool velocity_motion) {
  RandomProblemOptions options;
  options.seed = seed;
  options.num_poses = num_poses;
  options.num_features = 14;
  options.range_bearing = range_bearing;
  options.velocity_motion = velocity_motion;
  RandomProblem random = MakeRandomProblem(options);
  std::mt19937 rng(seed + 100);
  std::normal_distribution<double> normal(0.0, 1.0);
  core::Problem2d& p = random.problem;
  for (int i = 1; i < p.num_poses(); ++i)
    p.poses[i] += Eigen::Vector3d(1.0 * normal(rng), 1.0 * normal(rng), 0.6 * normal(rng));
  for (int j = 0; j < p.num_features(); ++j)
    p.features[j] += Eigen::Vector2d(2.0 * normal(rng), 2.0 * normal(rng));
  return random;
}

// chi2 at the optimum: dense Gauss-Newton from the ground truth.
inline double DenseOptimum(const RandomProblem& random) {
  core::Problem2d truth = random.problem;
  truth.poses = random.true_poses;
  truth.features = random.true_features;
  DenseReference dense(truth);
  return dense.Chi2(dense.SolveGaussNewton(30));
}

// The full solve of *problem in memory (default chunking); a failure fails
// the calling test.
inline core::SolverSummary FullSolve(core::Problem2d* problem,
                                     const core::SolverOptions& options) {
  partition::InMemoryChunkSource chunks(*problem, partition::ChunkingOptions());
  core::SolverSummary summary;
  Status status = core::SolveGraphSlam(options, chunks, problem, &summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return summary;
}

}  // namespace graphslam::testing
