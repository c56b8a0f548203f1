// IncompleteCholeskyPreconditioner against dense reference math: PCG
// with it equals a dense LDLT solve on random seeded SPD block
// systems; its product equals Eigen's own IncompleteCholesky::solve and is a
// symmetric positive definite operator; and on a loop-closing pose graph it
// needs far fewer PCG iterations than block-Jacobi (counts and times printed).
#include "core/incomplete_cholesky_preconditioner.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <Eigen/IterativeLinearSolvers>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <numbers>
#include <random>
#include <thread>
#include <utility>
#include <vector>

#include "core/block_jacobi_preconditioner.h"
#include "core/block_sparse_matrix.h"
#include "core/preconditioned_conjugate_gradient.h"
#include "core/relative_pose_model.h"
#include "core/se2.h"
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

TEST(IncompleteCholeskyPreconditioner, PcgSolveEqualsDenseSolve) {
  for (int b : {1, 3, 6}) {
    for (uint32_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      const int n = seed == 5 ? 300 : 20 + 10 * static_cast<int>(seed);
      const BlockSparseMatrix a = RandomSpdMatrix(seed + 70, b, n);
      const Eigen::VectorXd rhs = RandomVector(seed + 3000, a.num_rows());
      const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
      IncompleteCholeskyOptions ic_options;
      ic_options.fill_levels = static_cast<int>(seed % 3);  // 0, 1 and 2
      IncompleteCholeskyPreconditioner incomplete_cholesky(ic_options);
      ASSERT_TRUE(incomplete_cholesky.Update(a).ok());
      EXPECT_EQ(incomplete_cholesky.num_rows(), a.num_rows());
      // Eigen keeps p_j largest entries per column: exactly the budget tril(G).
      EXPECT_EQ(incomplete_cholesky.num_factor_nonzeros(),
                incomplete_cholesky.num_pattern_nonzeros());
      PcgOptions options;
      options.max_iterations = 10 * a.num_rows();
      options.relative_tolerance = 1e-12;
      Eigen::VectorXd x;
      const PcgSummary summary = SolvePcg(a, incomplete_cholesky, rhs, options, &x);
      EXPECT_TRUE(summary.converged) << "iterations " << summary.iterations << ", residual "
                                     << summary.relative_residual;
      // Relative 1e-8 on x (condition numbers up to ~1e4, residual 1e-12).
      EXPECT_LE(RelativeError(x, expected), 1e-8)
          << "pcg:   " << x.transpose() << "\ndense: " << expected.transpose();
    }
  }
}

TEST(IncompleteCholeskyPreconditioner, ProductEqualsEigenSolveAndIsSymmetricPositiveDefinite) {
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    const BlockSparseMatrix a = RandomSpdMatrix(seed + 90, 3, 25);
    // fill_levels 0: the matrix handed to Eigen is exactly tril(A).
    IncompleteCholeskyOptions options;
    options.fill_levels = 0;
    IncompleteCholeskyPreconditioner incomplete_cholesky(options);
    ASSERT_TRUE(incomplete_cholesky.Update(a).ok());
    EXPECT_EQ(incomplete_cholesky.num_pattern_nonzeros(), a.ToSparseUpper().nonZeros());

    // Reference: Eigen's own solve with the same factor (same input, same
    // deterministic factorization), through its generic permutation and
    // triangular-view code rather than our raw-array loops.
    Eigen::SparseMatrix<double> upper = a.ToSparseUpper();
    const Eigen::SparseMatrix<double> lower = upper.transpose();
    Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>> reference(lower);
    ASSERT_EQ(reference.info(), Eigen::Success);
    const Eigen::VectorXd x = RandomVector(seed + 4000, a.num_rows());
    const Eigen::VectorXd y0 = RandomVector(seed + 5000, a.num_rows());
    Eigen::VectorXd y = y0;
    incomplete_cholesky.RightMultiplyAndAccumulate(x.data(), y.data());
    const Eigen::VectorXd expected = y0 + Eigen::VectorXd(reference.solve(x));
    // Relative 1e-12: same factor, only the summation order may differ.
    EXPECT_LE(RelativeError(y, expected), 1e-12)
        << "ours:  " << y.transpose() << "\neigen: " << expected.transpose();

    // PCG needs M^{-1} symmetric positive definite.
    // PCG needs M^{-1} symmetric positive definite, with and without fill.
    for (int fill_levels : {0, 1, 2}) {
      SCOPED_TRACE(::testing::Message() << "fill_levels " << fill_levels);
      options.fill_levels = fill_levels;
      IncompleteCholeskyPreconditioner with_fill(options);
      ASSERT_TRUE(with_fill.Update(a).ok());
      const Eigen::MatrixXd inverse = DenseMatrixOf(with_fill);
      // Relative 1e-12: the two triangular solves are transposes of each
      // other, so asymmetry is rounding only.
      EXPECT_LE((inverse - inverse.transpose()).norm(), 1e-12 * inverse.norm());
      const Eigen::VectorXd eigenvalues =
          Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(0.5 * (inverse + inverse.transpose()))
              .eigenvalues();
      EXPECT_GT(eigenvalues.minCoeff(), 0.0) << eigenvalues.transpose();
    }
  }
}

TEST(IncompleteCholeskyPreconditioner, IsExactOnABlockTridiagonalMatrix) {
  // A chain has no fill under AMD (its graph is an interval graph, eliminated
  // leaf-first), so nothing is dropped and L L^T is the exact Cholesky factor.
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const int fill_levels = static_cast<int>(seed) - 1;  // 0, 1, 2
    SCOPED_TRACE(::testing::Message() << "seed " << seed << ", fill_levels " << fill_levels);
    const int n = 40;
    std::vector<std::pair<int, int>> pairs;
    for (int i = 0; i + 1 < n; ++i) pairs.emplace_back(i, i + 1);
    BlockSparseMatrix a = BlockSparseMatrix::FromPattern(3, n, pairs);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> value(-1.0, 1.0);
    for (const auto& [i, k] : pairs) {
      Eigen::Matrix3d block;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) block(r, c) = value(rng);
      ASSERT_TRUE(a.AddBlock(i, k, block));
    }
    for (int i = 0; i < n; ++i) ASSERT_TRUE(a.AddBlock(i, i, 7.0 * Eigen::Matrix3d::Identity()));
    IncompleteCholeskyOptions options;
    options.fill_levels = fill_levels;
    IncompleteCholeskyPreconditioner incomplete_cholesky(options);
    ASSERT_TRUE(incomplete_cholesky.Update(a).ok());
    const Eigen::MatrixXd inverse = DenseMatrixOf(incomplete_cholesky);
    const Eigen::MatrixXd expected = a.ToDense().inverse();
    // Relative 1e-10 (A is diagonally dominant, condition < 10).
    EXPECT_LE((inverse - expected).norm(), 1e-10 * expected.norm());
  }
}

TEST(IncompleteCholeskyPreconditioner, ConcurrentProductsEqualSerialBitForBit) {
  const BlockSparseMatrix a = RandomSpdMatrix(7, 3, 200);
  IncompleteCholeskyPreconditioner incomplete_cholesky;
  ASSERT_TRUE(incomplete_cholesky.Update(a).ok());
  constexpr int kThreads = 4;
  std::vector<Eigen::VectorXd> inputs, serial, parallel;
  for (int t = 0; t < kThreads; ++t) {
    inputs.push_back(RandomVector(100 + t, a.num_rows()));
    serial.push_back(Eigen::VectorXd::Zero(a.num_rows()));
    parallel.push_back(Eigen::VectorXd::Zero(a.num_rows()));
    incomplete_cholesky.RightMultiplyAndAccumulate(inputs[t].data(), serial[t].data());
  }
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t) {
    threads.emplace_back([&, t] {
      for (int repeat = 0; repeat < 50; ++repeat) {
        parallel[t].setZero();
        incomplete_cholesky.RightMultiplyAndAccumulate(inputs[t].data(), parallel[t].data());
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int t = 0; t < kThreads; ++t) {
    EXPECT_EQ((parallel[t] - serial[t]).norm(), 0.0) << "thread " << t;
  }
}

TEST(IncompleteCholeskyPreconditioner, FailuresNameTheQuantityAndKeepTheState) {
  const BlockSparseMatrix good = RandomSpdMatrix(5, 3, 6);
  IncompleteCholeskyPreconditioner incomplete_cholesky;
  ASSERT_TRUE(incomplete_cholesky.Update(good).ok());
  const Eigen::VectorXd x = RandomVector(9, good.num_rows());
  const Eigen::MatrixXd before = DenseMatrixOf(incomplete_cholesky);

  // Non-positive diagonal: rejected before Eigen would shift it away.
  BlockSparseMatrix bad = RandomSpdMatrix(5, 3, 6);
  Eigen::VectorXd shift = Eigen::VectorXd::Zero(bad.num_rows());
  shift[4 * 3 + 1] = -1e4;
  bad.AddToDiagonal(shift);
  Status status = incomplete_cholesky.Update(bad);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();
  EXPECT_NE(status.message().find("A(13, 13)"), std::string::npos) << status.ToString();
  EXPECT_NE(status.message().find("block row 4"), std::string::npos) << status.ToString();

  // Non-finite entry.
  BlockSparseMatrix not_finite = RandomSpdMatrix(5, 3, 6);
  not_finite.MutableBlock(2, 2)[0] = std::nan("");
  status = incomplete_cholesky.Update(not_finite);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();
  EXPECT_NE(status.message().find("A(6, 6) = nan is not finite"), std::string::npos)
      << status.ToString();

  // Indefinite with a positive diagonal: the scaled pivot 2 is (1 - 4)/sqrt(5)
  // and needs a shift above 0.447; Eigen tries at most 2^8 * 1e-3 = 0.256.
  BlockSparseMatrix indefinite = BlockSparseMatrix::FromPattern(3, 2, {{0, 1}});
  Eigen::Matrix3d block;
  block << 1, 2, 0, 2, 1, 0, 0, 0, 1;
  ASSERT_TRUE(indefinite.AddBlock(0, 0, block));
  ASSERT_TRUE(indefinite.AddBlock(1, 1, Eigen::Matrix3d::Identity()));
  status = incomplete_cholesky.Update(indefinite);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();
  EXPECT_NE(status.message().find("NumericalIssue"), std::string::npos) << status.ToString();
  EXPECT_NE(status.message().find("initial_shift = 0.001 to 0.256"), std::string::npos)
      << status.ToString();

  // Bad options are rejected before anything changes.
  IncompleteCholeskyOptions options;
  EXPECT_TRUE(options.Validate().ok());
  for (double bad_shift : {0.0, -1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    options.initial_shift = bad_shift;
    status = options.Validate();
    EXPECT_TRUE(status.IsInvalidArgument()) << status.ToString();
    EXPECT_NE(status.message().find("initial_shift"), std::string::npos) << status.ToString();
  }
  options = IncompleteCholeskyOptions();
  for (int bad_levels : {-1, IncompleteCholeskyOptions::kMaxFillLevels + 1}) {
    options.fill_levels = bad_levels;
    IncompleteCholeskyPreconditioner rejected(options);
    status = rejected.Update(good);
    EXPECT_TRUE(status.IsInvalidArgument()) << status.ToString();
    EXPECT_NE(status.message().find("fill_levels"), std::string::npos) << status.ToString();
    EXPECT_EQ(rejected.num_rows(), 0);
  }

  // Every failure above left the first factor in place, bit for bit.
  EXPECT_EQ(incomplete_cholesky.num_rows(), good.num_rows());
  EXPECT_EQ((DenseMatrixOf(incomplete_cholesky) - before).norm(), 0.0);

  // A larger initial shift makes the indefinite matrix factorable (M^{-1} is
  // then SPD, though no longer an approximation of A^{-1}).
  options = IncompleteCholeskyOptions();
  options.initial_shift = 1.0;
  IncompleteCholeskyPreconditioner shifted(options);
  EXPECT_TRUE(shifted.Update(indefinite).ok());
}

TEST(IncompleteCholeskyPreconditioner, EmptyMatrixIsANoOp) {
  IncompleteCholeskyPreconditioner incomplete_cholesky;
  EXPECT_TRUE(incomplete_cholesky.Update(BlockSparseMatrix::FromPattern(3, 0, {})).ok());
  EXPECT_EQ(incomplete_cholesky.num_rows(), 0);
  incomplete_cholesky.RightMultiplyAndAccumulate(nullptr, nullptr);
}

struct TimedSolve {
  PcgSummary summary;
  double update_seconds = 0;
  double solve_seconds = 0;
  Eigen::VectorXd x;
};

template <typename Preconditioner>
TimedSolve UpdateAndSolve(const BlockSparseMatrix& a, const Eigen::VectorXd& rhs,
                          const PcgOptions& options, Preconditioner* preconditioner) {
  using Clock = std::chrono::steady_clock;
  TimedSolve out;
  const auto start = Clock::now();
  const Status status = preconditioner->Update(a);
  const auto updated = Clock::now();
  EXPECT_TRUE(status.ok()) << status.ToString();
  out.summary = SolvePcg(a, *preconditioner, rhs, options, &out.x);
  const auto solved = Clock::now();
  out.update_seconds = std::chrono::duration<double>(updated - start).count();
  out.solve_seconds = std::chrono::duration<double>(solved - updated).count();
  return out;
}

TEST(IncompleteCholeskyPreconditioner, NeedsFarFewerPcgIterationsThanBlockJacobiOnAPoseGraph) {
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    // 20 x 25 = 500 poses, about a third of the possible closures.
    const LinearizedPoseGraph graph = MakeLoopClosingPoseGraph(seed, 20, 25, 0.3);
    const BlockSparseMatrix& a = graph.information;
    PcgOptions options;
    options.max_iterations = 10 * a.num_rows();
    options.relative_tolerance = 1e-8;

    BlockJacobiPreconditioner jacobi;
    const TimedSolve with_jacobi = UpdateAndSolve(a, graph.rhs, options, &jacobi);
    ASSERT_TRUE(with_jacobi.summary.converged);
    std::printf(
        "[ pose graph seed %u: %d poses, %d loop closures, %d x %d reduced system, PCG to 1e-8 ]\n"
        "  block-Jacobi:                        %4d iterations, update %7.3f ms, solve %7.3f ms\n",
        seed, a.num_block_rows() + 1, graph.num_loop_closures, a.num_rows(), a.num_rows(),
        with_jacobi.summary.iterations, 1e3 * with_jacobi.update_seconds,
        1e3 * with_jacobi.solve_seconds);
    // Relative 1e-6 against a dense LDLT for every solve: cond(A) ~ 4e6 here,
    // so a 1e-8 residual does not bound the error by 1e-6 a priori; observed
    // 2e-9 .. 7e-8 on these seeds.
    const Eigen::VectorXd expected = a.ToDense().ldlt().solve(graph.rhs);
    EXPECT_LE(RelativeError(with_jacobi.x, expected), 1e-6);

    // The default (fill_levels 1) is asserted; 0 and 2 are printed for scale.
    for (int fill_levels : {0, 1, 2}) {
      IncompleteCholeskyOptions ic_options;
      ic_options.fill_levels = fill_levels;
      IncompleteCholeskyPreconditioner incomplete_cholesky(ic_options);
      const TimedSolve with_ic = UpdateAndSolve(a, graph.rhs, options, &incomplete_cholesky);
      ASSERT_TRUE(with_ic.summary.converged);
      EXPECT_LE(RelativeError(with_ic.x, expected), 1e-6);
      std::printf(
          "  incomplete Cholesky, fill_levels %d:  %4d iterations, update %7.3f ms, solve %7.3f "
          "ms, nnz(L) = %lld = %.2f x nnz(tril A)\n",
          fill_levels, with_ic.summary.iterations, 1e3 * with_ic.update_seconds,
          1e3 * with_ic.solve_seconds,
          static_cast<long long>(incomplete_cholesky.num_factor_nonzeros()),
          static_cast<double>(incomplete_cholesky.num_factor_nonzeros()) /
              static_cast<double>(a.ToSparseUpper().nonZeros()));
      if (fill_levels == IncompleteCholeskyOptions().fill_levels) {
        EXPECT_LT(3 * with_ic.summary.iterations, with_jacobi.summary.iterations)
            << "incomplete Cholesky " << with_ic.summary.iterations << " vs block-Jacobi "
            << with_jacobi.summary.iterations;
      }
    }
  }
}

}  // namespace
}  // namespace graphslam::core
