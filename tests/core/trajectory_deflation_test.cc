// TrajectoryDeflation against dense reference math: deflated PCG (coarse
// correction, then PCG with the projected preconditioner) equals a dense LDLT
// solve on random seeded SPD block systems around both inner
// preconditioners; after the coarse correction the residual is orthogonal to
// every coarse vector (the constant and linear modes of each aggregate); and
// on a loop-closing pose graph it needs far fewer PCG iterations than
// block-Jacobi and fewer than the subgraph preconditioner alone.
#include "core/trajectory_deflation.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdio>
#include <vector>

#include "core/block_jacobi_preconditioner.h"
#include "core/preconditioned_conjugate_gradient.h"
#include "core/subgraph_preconditioner.h"
#include "tests/testing/loop_closing_pose_graph.h"
#include "tests/testing/random_linear_system.h"

namespace graphslam::core {
namespace {

using graphslam::testing::LinearizedPoseGraph;
using graphslam::testing::MakeLoopClosingPoseGraph;
using graphslam::testing::RandomSpdMatrix;
using graphslam::testing::RandomVector;
using graphslam::testing::RelativeError;

// Deflated PCG from x = 0 to `tolerance`.
PcgSummary DeflatedSolve(const BlockSparseMatrix& a, const Eigen::VectorXd& rhs,
                         const TrajectoryDeflation& deflation, double tolerance,
                         Eigen::VectorXd* x) {
  x->setZero(a.num_rows());
  EXPECT_TRUE(deflation.CoarseCorrect(a, rhs, x).ok());
  PcgOptions options;
  options.max_iterations = 10 * a.num_rows();
  options.relative_tolerance = tolerance;
  return SolvePcg(a, deflation, rhs, options, x);
}

TEST(TrajectoryDeflation, DeflatedPcgEqualsDenseSolve) {
  for (int b : {1, 3, 6}) {
    for (int m : {2, 5, 16}) {
      for (uint32_t seed = 1; seed <= 3; ++seed) {
        SCOPED_TRACE(::testing::Message() << "b " << b << ", m " << m << ", seed " << seed);
        const int n = 20 + 37 * static_cast<int>(seed);
        const BlockSparseMatrix a = RandomSpdMatrix(seed + 70, b, n);
        const Eigen::VectorXd rhs = RandomVector(seed + 900, a.num_rows());
        const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
        SubgraphPreconditioner subgraph;
        BlockJacobiPreconditioner jacobi;
        ASSERT_TRUE(subgraph.Update(a).ok());
        ASSERT_TRUE(jacobi.Update(a).ok());
        for (const LinearOperator* inner : {static_cast<const LinearOperator*>(&subgraph),
                                            static_cast<const LinearOperator*>(&jacobi)}) {
          TrajectoryDeflation deflation(inner, m, TrajectoryDeflation::DefaultLinearComponents(b));
          ASSERT_TRUE(deflation.Update(a).ok());
          EXPECT_EQ(deflation.num_aggregates(), std::max(1, n / m));
          Eigen::VectorXd x;
          const PcgSummary summary = DeflatedSolve(a, rhs, deflation, 1e-12, &x);
          EXPECT_TRUE(summary.converged) << "iterations " << summary.iterations;
          EXPECT_LE(RelativeError(x, expected), 1e-8);
        }
      }
    }
  }
}

TEST(TrajectoryDeflation, CoarseCorrectionLeavesAResidualOrthogonalToTheCoarseSpace) {
  const int b = 3, n = 53, m = 10;  // aggregates 0-9, ..., 40-52 (the last takes the rest)
  const BlockSparseMatrix a = RandomSpdMatrix(5, b, n);
  const Eigen::VectorXd rhs = RandomVector(6, a.num_rows());
  BlockJacobiPreconditioner jacobi;
  ASSERT_TRUE(jacobi.Update(a).ok());
  TrajectoryDeflation deflation(&jacobi, m, {0, 1, 2});
  ASSERT_TRUE(deflation.Update(a).ok());
  ASSERT_EQ(deflation.num_aggregates(), 5);
  EXPECT_EQ(deflation.coarse_unknowns(), 5 * 2 * b);
  Eigen::VectorXd x = RandomVector(7, a.num_rows());
  ASSERT_TRUE(deflation.CoarseCorrect(a, rhs, &x).ok());
  const Eigen::VectorXd r = rhs - a.ToDense() * x;
  for (int agg = 0; agg < 5; ++agg) {
    const int lo = agg * m, hi = agg == 4 ? n - 1 : lo + m - 1;
    for (int d = 0; d < b; ++d) {
      double constant = 0.0, linear = 0.0, scale = 0.0;
      for (int i = lo; i <= hi; ++i) {
        constant += r[i * b + d];
        linear += (i - 0.5 * (lo + hi)) / m * r[i * b + d];
        scale += std::abs(rhs[i * b + d]);
      }
      EXPECT_NEAR(constant, 0.0, 1e-10 * scale) << "aggregate " << agg << ", component " << d;
      EXPECT_NEAR(linear, 0.0, 1e-10 * scale) << "aggregate " << agg << ", component " << d;
    }
  }
  // The projected preconditioner keeps it so: z is A-orthogonal to W, i.e.
  // W^T A z = 0 for z = (I - W E^{-1} (AW)^T) M^{-1} r.
  Eigen::VectorXd z = Eigen::VectorXd::Zero(a.num_rows());
  deflation.RightMultiplyAndAccumulate(r.data(), z.data());
  const Eigen::VectorXd az = a.ToDense() * z;
  for (int agg = 0; agg < 5; ++agg) {
    const int lo = agg * m, hi = agg == 4 ? n - 1 : lo + m - 1;
    double constant = 0.0, scale = 0.0;
    for (int i = lo; i <= hi; ++i) {
      constant += az[i * b];
      scale += std::abs(az[i * b]);
    }
    EXPECT_NEAR(constant, 0.0, 1e-9 * scale) << "aggregate " << agg;
  }
}

TEST(TrajectoryDeflation, TooFewPosesIsThePlainPreconditioner) {
  const BlockSparseMatrix a = RandomSpdMatrix(9, 3, 1);
  BlockJacobiPreconditioner jacobi;
  ASSERT_TRUE(jacobi.Update(a).ok());
  TrajectoryDeflation deflation(&jacobi, 4, {1});
  ASSERT_TRUE(deflation.Update(a).ok());
  EXPECT_EQ(deflation.num_aggregates(), 0);
  const Eigen::VectorXd rhs = RandomVector(10, 3);
  Eigen::VectorXd x;
  const PcgSummary summary = DeflatedSolve(a, rhs, deflation, 1e-12, &x);
  EXPECT_TRUE(summary.converged);
  EXPECT_LE(RelativeError(x, a.ToDense().ldlt().solve(rhs)), 1e-10);
}

TEST(TrajectoryDeflation, RejectsAnInnerPreconditionerOfAnotherSizeAndABadComponent) {
  const BlockSparseMatrix a = RandomSpdMatrix(11, 3, 20);
  const BlockSparseMatrix other = RandomSpdMatrix(12, 3, 21);
  BlockJacobiPreconditioner jacobi;
  ASSERT_TRUE(jacobi.Update(other).ok());
  TrajectoryDeflation deflation(&jacobi, 4, {1});
  EXPECT_EQ(deflation.Update(a).code(), Status::Code::kInvalidArgument);
  ASSERT_TRUE(jacobi.Update(a).ok());
  TrajectoryDeflation bad_component(&jacobi, 4, {3});  // blocks are 3 x 3
  EXPECT_EQ(bad_component.Update(a).code(), Status::Code::kInvalidArgument);
  TrajectoryDeflation good(&jacobi, 4, {2});
  EXPECT_TRUE(good.Update(a).ok());
  EXPECT_EQ(good.coarse_unknowns(), 5 * 4);
}

TEST(TrajectoryDeflation, CutsPcgIterationsOnALoopClosingPoseGraph) {
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    const LinearizedPoseGraph graph = MakeLoopClosingPoseGraph(seed, 20, 25, 0.3);
    const BlockSparseMatrix& a = graph.information;
    const Eigen::VectorXd expected = a.ToDense().ldlt().solve(graph.rhs);
    PcgOptions options;
    options.max_iterations = 10 * a.num_rows();
    options.relative_tolerance = 1e-8;
    BlockJacobiPreconditioner jacobi;
    SubgraphPreconditioner subgraph;
    ASSERT_TRUE(jacobi.Update(a).ok());
    ASSERT_TRUE(subgraph.Update(a).ok());
    Eigen::VectorXd x_jacobi, x_subgraph, x_deflated_jacobi, x_deflated;
    const PcgSummary jacobi_summary = SolvePcg(a, jacobi, graph.rhs, options, &x_jacobi);
    const PcgSummary subgraph_summary = SolvePcg(a, subgraph, graph.rhs, options, &x_subgraph);
    const std::vector<int> linear = TrajectoryDeflation::DefaultLinearComponents(3);
    TrajectoryDeflation deflated_jacobi(&jacobi, 10, linear), deflated(&subgraph, 10, linear);
    ASSERT_TRUE(deflated_jacobi.Update(a).ok());
    ASSERT_TRUE(deflated.Update(a).ok());
    const PcgSummary deflated_jacobi_summary =
        DeflatedSolve(a, graph.rhs, deflated_jacobi, 1e-8, &x_deflated_jacobi);
    const PcgSummary deflated_summary = DeflatedSolve(a, graph.rhs, deflated, 1e-8, &x_deflated);
    std::printf(
        "[ pose graph seed %u: %d poses, PCG to 1e-8 ]\n"
        "  block-Jacobi %d, deflated block-Jacobi (10 poses) %d, subgraph %d, deflated "
        "subgraph %d iterations\n",
        seed, a.num_block_rows() + 1, jacobi_summary.iterations,
        deflated_jacobi_summary.iterations, subgraph_summary.iterations,
        deflated_summary.iterations);
    ASSERT_TRUE(deflated_summary.converged);
    ASSERT_TRUE(deflated_jacobi_summary.converged);
    EXPECT_LE(RelativeError(x_deflated, expected), 1e-6);
    EXPECT_LE(RelativeError(x_deflated_jacobi, expected), 1e-6);
    // Deflation alone (around block-Jacobi) takes at most 0.6x its count
    // (measured 0.53-0.56x); around the tree less than half of block-Jacobi
    // and fewer than the tree alone (0.57-0.59x of it).
    EXPECT_LT(5 * deflated_jacobi_summary.iterations, 3 * jacobi_summary.iterations);
    EXPECT_LT(2 * deflated_summary.iterations, jacobi_summary.iterations);
    EXPECT_LT(deflated_summary.iterations, subgraph_summary.iterations);
  }
}

}  // namespace
}  // namespace graphslam::core
