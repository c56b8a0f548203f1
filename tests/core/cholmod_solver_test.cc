// CholmodSolver against dense LDLT solves on random seeded SPD block systems.
#include "core/cholmod_solver.h"
#include "tests/testing/random_linear_system.h"

#include <gtest/gtest.h>
#include <suitesparse/cholmod.h>

#include <Eigen/Dense>
#include <algorithm>
#include <memory>
#include <string>
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

// The supernodal matrix of a block ordering is put together block by block
// (core/cholmod_solver.cc): a pose graph's pattern (a chain with loop
// closures, blocks both above and below the diagonal once permuted), block
// sizes 3 and 6, solved as the dense matrix is.
TEST(CholmodSolver, SupernodalBlockOrderedSolveEqualsDenseSolve) {
  for (int b : {3, 6}) {
    SCOPED_TRACE(::testing::Message() << "block size " << b);
    const int n = 120;
    std::vector<std::pair<int, int>> pairs = RandomPairs(31, n);
    for (int i = 0; i + 40 < n; i += 7) pairs.emplace_back(i, i + 40);  // loop closures
    std::sort(pairs.begin(), pairs.end());
    pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
    BlockSparseMatrix a = BlockSparseMatrix::FromPattern(b, n, pairs);
    FillSpd(32, pairs, &a);
    CholmodSolver solver;
    ASSERT_TRUE(solver.Factorize(a).ok());
    ASSERT_TRUE(solver.supernodal());
    for (uint32_t seed : {33u, 34u}) {
      const Eigen::VectorXd rhs = RandomVector(seed, a.num_rows());
      Eigen::VectorXd x;
      ASSERT_TRUE(solver.Solve(rhs, &x).ok());
      EXPECT_LE(RelativeError(x, a.ToDense().ldlt().solve(rhs)), 1e-10);
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

// A block chain (pose odometry): a factor with few flops per nonzero, which
// CHOLMOD's rule factorizes simplicially.
std::vector<std::pair<int, int>> ChainPairs(int n) {
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i + 1 < n; ++i) pairs.emplace_back(i, i + 1);
  return pairs;
}

// Every block coupled to every other: dense supernodes.
std::vector<std::pair<int, int>> CompletePairs(int n) {
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i)
    for (int k = i + 1; k < n; ++k) pairs.emplace_back(i, k);
  return pairs;
}

TEST(CholmodSolver, SimplicialAndSupernodalBothSolveAndReportIndefiniteRows) {
  struct Case {
    const char* name;
    std::vector<std::pair<int, int>> pairs;
    int n;
    bool supernodal;
  };
  const std::vector<Case> cases = {{"chain", ChainPairs(80), 80, false},
                                   {"complete", CompletePairs(40), 40, true}};
  for (const Case& c : cases) {
    for (int b : {3, 6}) {
      SCOPED_TRACE(::testing::Message() << c.name << ", block size " << b);
      BlockSparseMatrix a = BlockSparseMatrix::FromPattern(b, c.n, c.pairs);
      FillSpd(21, c.pairs, &a);
      CholmodSolver solver;
      ASSERT_TRUE(solver.Factorize(a).ok());
      EXPECT_EQ(solver.supernodal(), c.supernodal);
      const Eigen::VectorXd rhs = RandomVector(22, a.num_rows());
      Eigen::VectorXd x;
      ASSERT_TRUE(solver.Solve(rhs, &x).ok());
      EXPECT_LE(RelativeError(x, a.ToDense().ldlt().solve(rhs)), 1e-10);

      // One indefinite scalar row: the failure names it in S's numbering
      // (the factorization runs on the permuted matrix).
      const int row = 7 * b + 1;
      Eigen::VectorXd shift = Eigen::VectorXd::Zero(a.num_rows());
      shift[row] = -1e4;
      a.AddToDiagonal(shift);
      const Status status = solver.Factorize(a);
      EXPECT_TRUE(status.IsNumerical()) << status.ToString();
      const std::string expected_row = "row " + std::to_string(row) + " (block row 7)";
      EXPECT_NE(status.message().find(expected_row), std::string::npos)
          << status.ToString();
      a.AddToDiagonal(-shift);
      ASSERT_TRUE(solver.Factorize(a).ok());
      ASSERT_TRUE(solver.Solve(rhs, &x).ok());
      EXPECT_LE(RelativeError(x, a.ToDense().ldlt().solve(rhs)), 1e-10);
      EXPECT_EQ(solver.num_analyses(), 1);
    }
  }
}

TEST(CholmodSolver, UsesAHandedOverOrderingOnlyForItsPattern) {
  const int n = 50;
  const auto pairs = RandomPairs(12, n);
  BlockSparseMatrix a = BlockSparseMatrix::FromPattern(3, n, pairs);
  FillSpd(12, pairs, &a);
  StatusOr<std::shared_ptr<const CholmodOrdering>> ordering = AnalyzeCholmodOrdering(a);
  ASSERT_TRUE(ordering.ok()) << ordering.status().ToString();
  // A permutation of the scalar rows, with the factor's size and cost.
  std::vector<int> sorted = (*ordering)->permutation;
  std::sort(sorted.begin(), sorted.end());
  for (int k = 0; k < a.num_rows(); ++k) ASSERT_EQ(sorted[k], k);
  EXPECT_GT((*ordering)->factor_nonzeros, 0.0);
  EXPECT_GT((*ordering)->factor_flops, 0.0);
  EXPECT_TRUE((*ordering)->Orders(a));

  const Eigen::VectorXd rhs = RandomVector(13, a.num_rows());
  const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
  CholmodSolver solver;
  solver.UseOrdering(*ordering);
  ASSERT_TRUE(solver.Factorize(a).ok());
  Eigen::VectorXd x;
  ASSERT_TRUE(solver.Solve(rhs, &x).ok());
  EXPECT_LE(RelativeError(x, expected), 1e-10);

  // Another pattern: the ordering does not order it and is not used.
  const auto other_pairs = RandomPairs(14, n);
  BlockSparseMatrix other = BlockSparseMatrix::FromPattern(3, n, other_pairs);
  FillSpd(14, other_pairs, &other);
  EXPECT_FALSE((*ordering)->Orders(other));
  ASSERT_TRUE(solver.Factorize(other).ok());
  ASSERT_TRUE(solver.Solve(rhs, &x).ok());
  EXPECT_LE(RelativeError(x, other.ToDense().ldlt().solve(rhs)), 1e-10);
  EXPECT_EQ(solver.num_analyses(), 2);
}

// The scalar upper triangle of a block pattern as the solver stores it:
// every block of `pairs` and every diagonal block dense (b x b, the diagonal
// ones triangular), compressed by columns with sorted rows.
struct ScalarPattern {
  std::vector<int> col_start{0};
  std::vector<int> rows;

  cholmod_sparse View() {
    cholmod_sparse view{};
    view.nrow = view.ncol = col_start.size() - 1;
    view.nzmax = rows.size();
    view.p = col_start.data();
    view.i = rows.data();
    view.stype = 1;
    view.itype = CHOLMOD_INT;
    view.xtype = CHOLMOD_PATTERN;
    view.dtype = CHOLMOD_DOUBLE;
    view.sorted = 1;
    view.packed = 1;
    return view;
  }
};

ScalarPattern MakeScalarPattern(const std::vector<std::pair<int, int>>& pairs, int n, int b) {
  std::vector<std::vector<int>> block_rows(n);
  for (const auto& [i, k] : pairs) block_rows[std::max(i, k)].push_back(std::min(i, k));
  ScalarPattern pattern;
  for (int k = 0; k < n; ++k) {
    block_rows[k].push_back(k);
    std::sort(block_rows[k].begin(), block_rows[k].end());
    for (int c = 0; c < b; ++c) {
      for (int i : block_rows[k]) {
        const int last = i == k ? c : b - 1;
        for (int r = 0; r <= last; ++r) pattern.rows.push_back(i * b + r);
      }
      pattern.col_start.push_back(static_cast<int>(pattern.rows.size()));
    }
  }
  return pattern;
}

// The ordering is found on the block graph; its factor's size and cost must
// be CHOLMOD's own counts for the scalar matrix under that permutation.
TEST(CholmodSolver, BlockOrderingCountsAreThoseOfTheScalarFactor) {
  for (int b : {3, 6}) {
    for (uint32_t seed = 31; seed <= 33; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      const int n = 60;
      const auto pairs = RandomPairs(seed, n);
      BlockSparseMatrix a = BlockSparseMatrix::FromPattern(b, n, pairs);
      FillSpd(seed, pairs, &a);
      StatusOr<std::shared_ptr<const CholmodOrdering>> ordering = AnalyzeCholmodOrdering(a);
      ASSERT_TRUE(ordering.ok()) << ordering.status().ToString();

      // CHOLMOD's analysis of the scalar upper triangle with the given order.
      ScalarPattern pattern = MakeScalarPattern(pairs, n, b);
      cholmod_sparse view = pattern.View();
      cholmod_common common;
      cholmod_start(&common);
      common.print = 0;
      common.nmethods = 1;
      common.method[0].ordering = CHOLMOD_GIVEN;
      common.postorder = 0;
      common.supernodal = CHOLMOD_SIMPLICIAL;
      std::vector<int> permutation = (*ordering)->permutation;
      cholmod_factor* factor =
          cholmod_analyze_p(&view, permutation.data(), nullptr, 0, &common);
      ASSERT_NE(factor, nullptr);
      EXPECT_EQ((*ordering)->factor_nonzeros, common.lnz);
      EXPECT_EQ((*ordering)->factor_flops, common.fl);
      cholmod_free_factor(&factor, &common);
      cholmod_finish(&common);

      const Eigen::VectorXd rhs = RandomVector(seed, a.num_rows());
      CholmodSolver solver;
      solver.UseOrdering(*ordering);
      ASSERT_TRUE(solver.Factorize(a).ok());
      Eigen::VectorXd x;
      ASSERT_TRUE(solver.Solve(rhs, &x).ok());
      EXPECT_LE(RelativeError(x, a.ToDense().ldlt().solve(rhs)), 1e-10);
    }
  }
}

// A 3-D grid of 13^3 poses (6 x 6 blocks): AMD's factor is large and dense
// (over 500 flops per nonzero and over 5 nonzeros per matrix nonzero), where
// CHOLMOD's default strategy also weighs METIS, so the ordering comes from
// the scalar pattern. Checked by its residual (a dense reference of 13 182
// rows would take longer than the test may).
TEST(CholmodSolver, LargeDenseFactorsAreOrderedOnTheScalarPattern) {
  const int k = 13, b = 6, n = k * k * k;
  const auto index = [&](int x, int y, int z) { return (x * k + y) * k + z; };
  std::vector<std::pair<int, int>> pairs;
  for (int x = 0; x < k; ++x)
    for (int y = 0; y < k; ++y)
      for (int z = 0; z < k; ++z) {
        if (x + 1 < k) pairs.emplace_back(index(x, y, z), index(x + 1, y, z));
        if (y + 1 < k) pairs.emplace_back(index(x, y, z), index(x, y + 1, z));
        if (z + 1 < k) pairs.emplace_back(index(x, y, z), index(x, y, z + 1));
      }
  std::sort(pairs.begin(), pairs.end());
  BlockSparseMatrix a = BlockSparseMatrix::FromPattern(b, n, pairs);
  // Entries in [-1, 1]; at most 7 blocks of 6 per row, so a diagonal of 50
  // makes the matrix diagonally dominant, hence SPD.
  std::mt19937 rng(41);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  for (const auto& [i, j] : pairs) {
    Eigen::MatrixXd block(b, b);
    for (int r = 0; r < b; ++r)
      for (int c = 0; c < b; ++c) block(r, c) = value(rng);
    ASSERT_TRUE(a.AddBlock(i, j, block));
  }
  a.AddToDiagonal(Eigen::VectorXd::Constant(a.num_rows(), 50.0));

  StatusOr<std::shared_ptr<const CholmodOrdering>> ordering = AnalyzeCholmodOrdering(a);
  ASSERT_TRUE(ordering.ok()) << ordering.status().ToString();
  const double matrix_nonzeros =
      static_cast<double>(pairs.size()) * b * b + static_cast<double>(n) * b * (b + 1) / 2;
  EXPECT_GE((*ordering)->factor_flops, 500.0 * (*ordering)->factor_nonzeros);
  EXPECT_GE((*ordering)->factor_nonzeros, 5.0 * matrix_nonzeros);
  // CHOLMOD's default analysis of the scalar pattern, permutation and all.
  ScalarPattern pattern = MakeScalarPattern(pairs, n, b);
  cholmod_sparse view = pattern.View();
  cholmod_common common;
  cholmod_start(&common);
  common.print = 0;
  common.supernodal = CHOLMOD_SIMPLICIAL;
  cholmod_factor* factor = cholmod_analyze(&view, &common);
  ASSERT_NE(factor, nullptr);
  const int* scalar_perm = static_cast<const int*>(factor->Perm);
  EXPECT_EQ((*ordering)->permutation, std::vector<int>(scalar_perm, scalar_perm + a.num_rows()));
  EXPECT_EQ((*ordering)->factor_nonzeros, common.lnz);
  cholmod_free_factor(&factor, &common);
  cholmod_finish(&common);

  const Eigen::VectorXd rhs = RandomVector(42, a.num_rows());
  CholmodSolver solver;
  solver.UseOrdering(*ordering);
  ASSERT_TRUE(solver.Factorize(a).ok());
  EXPECT_TRUE(solver.supernodal());
  Eigen::VectorXd x;
  ASSERT_TRUE(solver.Solve(rhs, &x).ok());
  Eigen::VectorXd product = Eigen::VectorXd::Zero(a.num_rows());
  a.RightMultiplyAndAccumulate(x.data(), product.data());
  EXPECT_LE((product - rhs).norm(), 1e-10 * rhs.norm());
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
