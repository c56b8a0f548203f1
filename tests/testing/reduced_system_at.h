// The reduced system as the solver hands it to ReducePass, for the chunk-pass
// tests of both spaces: the pattern of S (pose factors plus the pairs the
// observations couple), zeroed, with the pose-only factors at `poses` added
// (gradient, diag(H_xx), and rhs = -g_x); and the relative difference the
// tests compare systems by.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <utility>
#include <vector>

#include "core/chunk_passes.h"
#include "core/pose_factors.h"

namespace graphslam::testing {

template <class Space>
core::ReducedSystem ReducedSystemAt(const typename Space::Problem& problem,
                                    const core::BasicPassContext<Space>& context,
                                    const std::vector<typename Space::Pose>& poses) {
  std::vector<std::pair<int, int>> pairs;
  core::AppendPoseFactorPattern(problem, *context.layout, &pairs);
  EXPECT_TRUE(core::CollectReducedPattern(context, &pairs).ok());
  core::ReducedSystem system;
  system.matrix =
      core::BlockSparseMatrix::FromPattern(Space::kPoseDim, context.layout->num_blocks(), pairs);
  const int n = system.matrix.num_rows();
  system.matrix.SetZero();
  system.rhs.setZero(n);
  system.gradient.setZero(n);
  system.hessian_diagonal.setZero(n);
  core::LinearizePoseFactors(problem, poses, *context.layout, &system.matrix, &system.gradient,
                             &system.hessian_diagonal);
  system.rhs -= system.gradient;
  return system;
}

// |a - b| / |b| (Frobenius), for comparing a pass's S, rhs or gradient with a
// reference; b = 0 is guarded.
inline double RelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return (a - b).norm() / std::max(b.norm(), 1e-300);
}

}  // namespace graphslam::testing
