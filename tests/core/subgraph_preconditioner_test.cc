// SubgraphPreconditioner against dense reference math: PCG with it equals a
// dense LDLT solve on random seeded SPD block systems; on a matrix whose graph
// is a tree it is the exact inverse; M^{-1} is symmetric positive definite,
// also when the diagonal compensation is needed; and on a loop-closing pose
// graph it needs far fewer PCG iterations than block-Jacobi (counts printed
// beside incomplete Cholesky for the choice recorded in docs/benchmarks.md).
#include "core/subgraph_preconditioner.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <chrono>
#include <cstdio>
#include <random>
#include <thread>
#include <utility>
#include <vector>

#include "core/block_jacobi_preconditioner.h"
#include "core/incomplete_cholesky_preconditioner.h"
#include "core/preconditioned_conjugate_gradient.h"
#include "tests/testing/dense_operator.h"
#include "tests/testing/loop_closing_pose_graph.h"
#include "tests/testing/random_linear_system.h"

namespace graphslam::core {
namespace {

using graphslam::testing::DenseMatrixOf;
using graphslam::testing::LinearizedPoseGraph;
using graphslam::testing::MakeLoopClosingPoseGraph;
using graphslam::testing::RandomSpdMatrix;
using graphslam::testing::RandomVector;
using graphslam::testing::RelativeError;

TEST(SubgraphPreconditioner, PcgSolveEqualsDenseSolve) {
  for (int b : {1, 3, 6}) {
    for (uint32_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      const int n = seed == 5 ? 300 : 20 + 10 * static_cast<int>(seed);
      const BlockSparseMatrix a = RandomSpdMatrix(seed + 170, b, n);
      const Eigen::VectorXd rhs = RandomVector(seed + 3100, a.num_rows());
      const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
      SubgraphPreconditioner subgraph;
      ASSERT_TRUE(subgraph.Update(a).ok());
      EXPECT_EQ(subgraph.num_rows(), a.num_rows());
      // The random matrix is connected (it contains a chain): one tree.
      EXPECT_EQ(subgraph.num_tree_edges(), n - 1);
      PcgOptions options;
      options.max_iterations = 10 * a.num_rows();
      options.relative_tolerance = 1e-12;
      Eigen::VectorXd x;
      const PcgSummary summary = SolvePcg(a, subgraph, rhs, options, &x);
      EXPECT_TRUE(summary.converged) << "iterations " << summary.iterations;
      EXPECT_LE(RelativeError(x, expected), 1e-8);
    }
  }
}

// A random tree (each block row i > 0 joined to a random earlier one) plus
// isolated blocks: the forest is the whole graph, so M = A.
TEST(SubgraphPreconditioner, IsTheExactInverseOnAForest) {
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> value(-1.0, 1.0);
    const int n = 60, isolated = 5;
    std::vector<std::pair<int, int>> pairs;
    for (int i = 1; i < n - isolated; ++i)
      pairs.emplace_back(std::uniform_int_distribution<int>(0, i - 1)(rng), i);
    BlockSparseMatrix a = BlockSparseMatrix::FromPattern(3, n, pairs);
    for (const auto& [i, k] : pairs) {
      Eigen::Matrix3d block;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) block(r, c) = value(rng);
      ASSERT_TRUE(a.AddBlock(i, k, block));
    }
    // Strict diagonal dominance: degree * 3 + 1 on the diagonal.
    std::vector<int> degree(n, 0);
    for (const auto& [i, k] : pairs) ++degree[i], ++degree[k];
    for (int i = 0; i < n; ++i)
      ASSERT_TRUE(a.AddBlock(i, i, (3.0 * degree[i] + 1.0) * Eigen::Matrix3d::Identity()));
    SubgraphPreconditioner subgraph;
    ASSERT_TRUE(subgraph.Update(a).ok());
    EXPECT_EQ(subgraph.num_tree_edges(), static_cast<int>(pairs.size()));
    EXPECT_FALSE(subgraph.compensated());
    const Eigen::MatrixXd inverse = DenseMatrixOf(subgraph);
    const Eigen::MatrixXd expected = a.ToDense().inverse();
    EXPECT_LE((inverse - expected).norm(), 1e-12 * expected.norm());
  }
}

TEST(SubgraphPreconditioner, CompensatesWhenTheTreeAloneIsIndefinite) {
  // A = G + 0.01 I with G the Gram matrix of u1 = u3 = (1,0,0)-like blocks:
  // A is SPD, but keeping A_12, A_23 (heaviest) and dropping A_13 makes the
  // tree matrix indefinite (its determinant is negative).
  BlockSparseMatrix a = BlockSparseMatrix::FromPattern(1, 3, {{0, 1}, {1, 2}, {0, 2}});
  ASSERT_TRUE(a.AddBlock(0, 1, Eigen::Matrix<double, 1, 1>(1.0)));
  ASSERT_TRUE(a.AddBlock(1, 2, Eigen::Matrix<double, 1, 1>(1.0)));
  ASSERT_TRUE(a.AddBlock(0, 2, Eigen::Matrix<double, 1, 1>(0.999)));
  for (int i = 0; i < 3; ++i) ASSERT_TRUE(a.AddBlock(i, i, Eigen::Matrix<double, 1, 1>(1.01)));
  ASSERT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(a.ToDense()).eigenvalues().minCoeff(),
            0.0);
  SubgraphPreconditioner subgraph;
  ASSERT_TRUE(subgraph.Update(a).ok());
  EXPECT_TRUE(subgraph.compensated());
  const Eigen::MatrixXd inverse = DenseMatrixOf(subgraph);
  EXPECT_LE((inverse - inverse.transpose()).norm(), 1e-12 * inverse.norm());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(inverse).eigenvalues().minCoeff(), 0.0);
  // M = A + compensation >= A, so M^{-1} <= A^{-1}: A^{-1} - M^{-1} is PSD.
  const Eigen::MatrixXd gap = a.ToDense().inverse() - inverse;
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(gap).eigenvalues().minCoeff(), -1e-10);
  const Eigen::VectorXd rhs = RandomVector(3, 3);
  PcgOptions options;
  options.relative_tolerance = 1e-12;
  Eigen::VectorXd x;
  EXPECT_TRUE(SolvePcg(a, subgraph, rhs, options, &x).converged);
  EXPECT_LE(RelativeError(x, a.ToDense().ldlt().solve(rhs)), 1e-9);
}

TEST(SubgraphPreconditioner, RejectsNonFiniteAndKeepsTheState) {
  const BlockSparseMatrix good = RandomSpdMatrix(5, 3, 6);
  SubgraphPreconditioner subgraph;
  ASSERT_TRUE(subgraph.Update(good).ok());
  const Eigen::MatrixXd before = DenseMatrixOf(subgraph);
  BlockSparseMatrix bad = RandomSpdMatrix(5, 3, 6);
  bad.MutableBlock(2, 2)[0] = std::nan("");
  const Status status = subgraph.Update(bad);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();
  EXPECT_NE(status.message().find("block row 2"), std::string::npos) << status.ToString();
  EXPECT_EQ((DenseMatrixOf(subgraph) - before).norm(), 0.0);
}

TEST(SubgraphPreconditioner, EmptyMatrixIsANoOp) {
  SubgraphPreconditioner subgraph;
  EXPECT_TRUE(subgraph.Update(BlockSparseMatrix::FromPattern(3, 0, {})).ok());
  EXPECT_EQ(subgraph.num_rows(), 0);
  subgraph.RightMultiplyAndAccumulate(nullptr, nullptr);
}

template <typename Preconditioner>
PcgSummary UpdateAndSolve(const BlockSparseMatrix& a, const Eigen::VectorXd& rhs,
                          const PcgOptions& options, Preconditioner* preconditioner,
                          Eigen::VectorXd* x, double* seconds) {
  const auto start = std::chrono::steady_clock::now();
  const Status status = preconditioner->Update(a);
  EXPECT_TRUE(status.ok()) << status.ToString();
  const PcgSummary summary = SolvePcg(a, *preconditioner, rhs, options, x);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

TEST(SubgraphPreconditioner, NeedsFarFewerPcgIterationsThanBlockJacobiOnAPoseGraph) {
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    const LinearizedPoseGraph graph = MakeLoopClosingPoseGraph(seed, 20, 25, 0.3);
    const BlockSparseMatrix& a = graph.information;
    PcgOptions options;
    options.max_iterations = 10 * a.num_rows();
    options.relative_tolerance = 1e-8;
    const Eigen::VectorXd expected = a.ToDense().ldlt().solve(graph.rhs);

    Eigen::VectorXd x_jacobi, x_subgraph, x_ic;
    double t_jacobi = 0, t_subgraph = 0, t_ic = 0;
    BlockJacobiPreconditioner jacobi;
    const PcgSummary jacobi_summary =
        UpdateAndSolve(a, graph.rhs, options, &jacobi, &x_jacobi, &t_jacobi);
    SubgraphPreconditioner subgraph;
    const PcgSummary subgraph_summary =
        UpdateAndSolve(a, graph.rhs, options, &subgraph, &x_subgraph, &t_subgraph);
    IncompleteCholeskyPreconditioner ic;
    const PcgSummary ic_summary = UpdateAndSolve(a, graph.rhs, options, &ic, &x_ic, &t_ic);
    std::printf(
        "[ pose graph seed %u: %d poses, %d loop closures, PCG to 1e-8 ]\n"
        "  block-Jacobi:        %4d iterations %8.3f ms\n"
        "  subgraph (tree):     %4d iterations %8.3f ms (compensated %d)\n"
        "  incomplete Cholesky: %4d iterations %8.3f ms\n",
        seed, a.num_block_rows() + 1, graph.num_loop_closures, jacobi_summary.iterations,
        1e3 * t_jacobi, subgraph_summary.iterations, 1e3 * t_subgraph,
        subgraph.compensated() ? 1 : 0, ic_summary.iterations, 1e3 * t_ic);
    ASSERT_TRUE(jacobi_summary.converged);
    ASSERT_TRUE(subgraph_summary.converged);
    ASSERT_TRUE(ic_summary.converged);
    EXPECT_LE(RelativeError(x_subgraph, expected), 1e-6);
    EXPECT_LE(RelativeError(x_ic, expected), 1e-6);
    // A real drop: at most half of block-Jacobi's count for both.
    EXPECT_LT(2 * subgraph_summary.iterations, jacobi_summary.iterations);
    EXPECT_LT(2 * ic_summary.iterations, jacobi_summary.iterations);
  }
}

}  // namespace
}  // namespace graphslam::core
