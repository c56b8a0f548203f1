// A linearized loop-closing pose graph for the preconditioner tests: PCG on
// it is slow with block-Jacobi (the error it leaves is smooth along the
// trajectory), which structural preconditioners must fix.
#pragma once

#include <gtest/gtest.h>

#include <Eigen/Core>
#include <cstdint>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/relative_pose_model.h"
#include "core/se2.h"

namespace graphslam::testing {

using core::BlockSparseMatrix;
using core::Pose2;

struct LinearizedPoseGraph {
  BlockSparseMatrix information;  // H = sum J^T W J, pose 0 anchored (removed)
  Eigen::VectorXd rhs;            // -g = -sum J^T W e
  int num_loop_closures = 0;
};

// A robot drives a serpentine over a rows x columns grid (1 m spacing, turning
// at the row ends), so consecutive rows run past each other in opposite
// directions; a loop closure joins pose (r, c) to pose (r + 1, c) with
// probability `closure_probability`. Odometry and closures are relative-pose
// constraints (core/relative_pose_model.h) measured from the true poses with
// noise, linearized at the true poses plus noise. Jacobians are taken w.r.t.
// the body-frame increment: J * core::RetractionJacobian(x) (core/se2.h).
inline LinearizedPoseGraph MakeLoopClosingPoseGraph(uint32_t seed, int rows, int columns,
                                                    double closure_probability) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  const int num_poses = rows * columns;
  auto pose_index = [&](int r, int c) { return r * columns + (r % 2 == 0 ? c : columns - 1 - c); };
  std::vector<Pose2> truth(num_poses), estimate(num_poses);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      const int p = pose_index(r, c);
      const bool row_end = (r % 2 == 0) ? c == columns - 1 : c == 0;
      const double heading =
          row_end ? std::numbers::pi / 2 : (r % 2 == 0 ? 0.0 : std::numbers::pi);
      truth[p] = Pose2(c, r, heading);
      estimate[p] = truth[p] + Pose2(0.05 * normal(rng), 0.05 * normal(rng), 0.01 * normal(rng));
    }
  }
  std::vector<std::pair<int, int>> edges;
  for (int p = 0; p + 1 < num_poses; ++p) edges.emplace_back(p, p + 1);
  LinearizedPoseGraph graph;
  for (int r = 0; r + 1 < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      const int from = pose_index(r, c), to = pose_index(r + 1, c);
      if (to != from + 1 && uniform(rng) < closure_probability) {
        edges.emplace_back(from, to);
        ++graph.num_loop_closures;
      }
    }
  }

  // Unknowns: poses 1..num_poses-1 as block rows 0..num_poses-2.
  std::vector<std::pair<int, int>> pairs;
  for (const auto& [i, j] : edges)
    if (i > 0) pairs.emplace_back(i - 1, j - 1);
  graph.information = BlockSparseMatrix::FromPattern(3, num_poses - 1, pairs);
  graph.rhs = Eigen::VectorXd::Zero(graph.information.num_rows());
  const Eigen::Vector3d sigma(0.05, 0.05, 0.01);
  const Eigen::Matrix3d weight = sigma.cwiseInverse().cwiseAbs2().asDiagonal();
  for (const auto& [i, j] : edges) {
    const Pose2 measurement = core::Between(truth[i], truth[j]) +
                              Pose2(sigma.x() * normal(rng), sigma.y() * normal(rng),
                                    sigma.z() * normal(rng));
    Eigen::Vector3d residual;
    Eigen::Matrix3d jacobian_from, jacobian_to;
    core::EvaluateRelativePose(estimate[i], estimate[j], measurement, &residual, &jacobian_from,
                         &jacobian_to);
    const Eigen::Matrix3d a_from = jacobian_from * core::RetractionJacobian(estimate[i]);
    const Eigen::Matrix3d a_to = jacobian_to * core::RetractionJacobian(estimate[j]);
    const Eigen::Matrix3d h_to_to = a_to.transpose() * weight * a_to;
    EXPECT_TRUE(graph.information.AddBlock(j - 1, j - 1, 0.5 * (h_to_to + h_to_to.transpose())));
    graph.rhs.segment<3>(3 * (j - 1)) -= a_to.transpose() * weight * residual;
    if (i == 0) continue;  // the anchor is not an unknown
    const Eigen::Matrix3d h_from_from = a_from.transpose() * weight * a_from;
    EXPECT_TRUE(
        graph.information.AddBlock(i - 1, i - 1, 0.5 * (h_from_from + h_from_from.transpose())));
    EXPECT_TRUE(graph.information.AddBlock(i - 1, j - 1, a_from.transpose() * weight * a_to));
    graph.rhs.segment<3>(3 * (i - 1)) -= a_from.transpose() * weight * residual;
  }
  return graph;
}

}  // namespace graphslam::testing
