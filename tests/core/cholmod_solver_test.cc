// CholmodSolver against dense LDLT solves on random seeded SPD block systems.
#include "core/cholmod_solver.h"
#include "tests/testing/random_linear_system.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"

namespace graphslam::core {
namespace {

using graphslam::testing::RelativeError;
using graphslam::testing::RandomVector;

std::vector<std::pair<int, int>> RandomPairs(uint32_t seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> index(0, n - 1);
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i + 1 < n; ++i) pairs.emplace_back(i, i + 1);
  for (int e = 0; e < n; ++e) {
    const int i = index(rng), k = index(rng);
    if (i != k) pairs.emplace_back(i, k);
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  return pairs;
}

// Fills `m` (pattern from `pairs`) with random values, strictly diagonally
// dominant, hence SPD.
void FillSpd(uint32_t seed, const std::vector<std::pair<int, int>>& pairs, BlockSparseMatrix* m) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  const int b = m->block_size();
  m->SetZero();
  for (const auto& [i, k] : pairs) {
    Eigen::MatrixXd block(b, b);
    for (int r = 0; r < b; ++r)
      for (int c = 0; c < b; ++c) block(r, c) = value(rng);
    ASSERT_TRUE(m->AddBlock(i, k, block));
  }
  const Eigen::VectorXd row_sums = m->ToDense().cwiseAbs().rowwise().sum();
  Eigen::VectorXd diagonal(m->num_rows());
  for (int j = 0; j < m->num_rows(); ++j) diagonal[j] = row_sums[j] + 0.1 + std::abs(value(rng));
  m->AddToDiagonal(diagonal);
}


TEST(CholmodSolver, SolveEqualsDenseSolve) {
  for (int b : {3, 6}) {
    for (uint32_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      const int n = 10 + 40 * static_cast<int>(seed);
      const auto pairs = RandomPairs(seed, n);
      BlockSparseMatrix a = BlockSparseMatrix::FromPattern(b, n, pairs);
      FillSpd(seed, pairs, &a);
      const Eigen::VectorXd rhs = RandomVector(seed, a.num_rows());
      const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
      CholmodSolver solver;
      ASSERT_TRUE(solver.Factorize(a).ok());
      Eigen::VectorXd x;
      ASSERT_TRUE(solver.Solve(rhs, &x).ok());
      // Relative 1e-10: diagonally dominant, well conditioned.
      EXPECT_LE(RelativeError(x, expected), 1e-10)
          << "cholmod: " << x.transpose() << "\ndense:   " << expected.transpose();
    }
  }
}

TEST(CholmodSolver, RefactorizingWithNewValuesReusesTheAnalysis) {
  const int n = 60;
  const auto pairs = RandomPairs(9, n);
  BlockSparseMatrix a = BlockSparseMatrix::FromPattern(3, n, pairs);
  CholmodSolver solver;
  for (uint32_t values_seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(::testing::Message() << "values seed " << values_seed);
    FillSpd(100 + values_seed, pairs, &a);
    ASSERT_TRUE(solver.Factorize(a).ok());
    const Eigen::VectorXd rhs = RandomVector(values_seed, a.num_rows());
    const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
    Eigen::VectorXd x;
    ASSERT_TRUE(solver.Solve(rhs, &x).ok());
    EXPECT_LE(RelativeError(x, expected), 1e-10)
        << "cholmod: " << x.transpose() << "\ndense:   " << expected.transpose();
  }
  EXPECT_EQ(solver.num_analyses(), 1);

  // A different pattern is analyzed again.
  const auto other_pairs = RandomPairs(10, n + 5);
  BlockSparseMatrix other = BlockSparseMatrix::FromPattern(3, n + 5, other_pairs);
  FillSpd(7, other_pairs, &other);
  ASSERT_TRUE(solver.Factorize(other).ok());
  EXPECT_EQ(solver.num_analyses(), 2);
  const Eigen::VectorXd rhs = RandomVector(11, other.num_rows());
  Eigen::VectorXd x;
  ASSERT_TRUE(solver.Solve(rhs, &x).ok());
  EXPECT_LE(RelativeError(x, other.ToDense().ldlt().solve(rhs)), 1e-10);
}

TEST(CholmodSolver, NonPositiveDefiniteMatrixIsReported) {
  const int n = 30;
  const auto pairs = RandomPairs(4, n);
  BlockSparseMatrix a = BlockSparseMatrix::FromPattern(3, n, pairs);
  FillSpd(4, pairs, &a);
  Eigen::VectorXd shift = Eigen::VectorXd::Zero(a.num_rows());
  shift[17 * 3 + 2] = -1e4;  // scalar row 53, block row 17
  a.AddToDiagonal(shift);
  CholmodSolver solver;
  const Status status = solver.Factorize(a);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();
  EXPECT_NE(status.message().find(
                "reduced information matrix is not positive definite (CHOLMOD)"),
            std::string::npos)
      << status.ToString();
  // Only row 53 is indefinite, so the first failing pivot is that row's.
  EXPECT_NE(status.message().find("row 53 (block row 17)"), std::string::npos)
      << status.ToString();
  EXPECT_FALSE(solver.factorized());

  // The same solver recovers once the matrix is positive definite again.
  a.AddToDiagonal(-shift);
  ASSERT_TRUE(solver.Factorize(a).ok());
  const Eigen::VectorXd rhs = RandomVector(4, a.num_rows());
  Eigen::VectorXd x;
  ASSERT_TRUE(solver.Solve(rhs, &x).ok());
  EXPECT_LE(RelativeError(x, a.ToDense().ldlt().solve(rhs)), 1e-10);
}

TEST(CholmodSolver, WrongRightHandSideSizeIsInvalidArgument) {
  const auto pairs = RandomPairs(5, 8);
  BlockSparseMatrix a = BlockSparseMatrix::FromPattern(3, 8, pairs);
  FillSpd(5, pairs, &a);
  CholmodSolver solver;
  ASSERT_TRUE(solver.Factorize(a).ok());
  Eigen::VectorXd x;
  const Status status = solver.Solve(Eigen::VectorXd::Ones(5), &x);
  EXPECT_TRUE(status.IsInvalidArgument()) << status.ToString();
}

}  // namespace
}  // namespace graphslam::core
