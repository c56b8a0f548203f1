// PCG against dense LDLT solves on random seeded SPD block systems.
#include "core/preconditioned_conjugate_gradient.h"
#include "tests/testing/random_linear_system.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "core/block_jacobi_preconditioner.h"
#include "core/block_sparse_matrix.h"

namespace graphslam::core {
namespace {

using graphslam::testing::RelativeError;
using graphslam::testing::RandomVector;
using graphslam::testing::RandomSpdMatrix;

class IdentityOperator : public LinearOperator {
 public:
  explicit IdentityOperator(int n) : n_(n) {}
  int num_rows() const override { return n_; }
  void RightMultiplyAndAccumulate(const double* x, double* y) const override {
    for (int i = 0; i < n_; ++i) y[i] += x[i];
  }

 private:
  int n_;
};

class DenseOperator : public LinearOperator {
 public:
  explicit DenseOperator(Eigen::MatrixXd a) : a_(std::move(a)) {}
  int num_rows() const override { return static_cast<int>(a_.rows()); }
  void RightMultiplyAndAccumulate(const double* x, double* y) const override {
    Eigen::Map<Eigen::VectorXd>(y, a_.rows()) +=
        a_ * Eigen::Map<const Eigen::VectorXd>(x, a_.cols());
  }

 private:
  Eigen::MatrixXd a_;
};


TEST(Pcg, EqualsDenseSolveWithoutPreconditioner) {
  for (int b : {3, 6}) {
    for (uint32_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      const BlockSparseMatrix a = RandomSpdMatrix(seed, b, 20 + 10 * seed);
      const Eigen::VectorXd rhs = RandomVector(seed + 1000, a.num_rows());
      const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
      PcgOptions options;
      options.max_iterations = 10 * a.num_rows();
      options.relative_tolerance = 1e-12;
      Eigen::VectorXd x;
      const PcgSummary summary = SolvePcg(a, IdentityOperator(a.num_rows()), rhs, options, &x);
      EXPECT_TRUE(summary.converged) << "iterations " << summary.iterations << ", residual "
                                     << summary.relative_residual;
      EXPECT_LE(summary.relative_residual, 1e-12);
      // Relative 1e-8 on x (condition numbers up to ~1e4 here).
      EXPECT_LE(RelativeError(x, expected), 1e-8)
          << "pcg:   " << x.transpose() << "\ndense: " << expected.transpose();
    }
  }
}

TEST(Pcg, BlockJacobiPreconditionedSolveEqualsDenseSolve) {
  for (int b : {3, 6}) {
    for (uint32_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      // One case large enough for the parallel products of both operators.
      const int n =
          (seed == 5 && b == 3) ? BlockSparseMatrix::kMinBlockRowsForParallel + 16 : 30;
      const BlockSparseMatrix a = RandomSpdMatrix(seed + 50, b, n);
      const Eigen::VectorXd rhs = RandomVector(seed + 2000, a.num_rows());
      const Eigen::VectorXd expected = a.ToDense().ldlt().solve(rhs);
      BlockJacobiPreconditioner jacobi;
      ASSERT_TRUE(jacobi.Update(a).ok());
      PcgOptions options;
      options.max_iterations = 10 * a.num_rows();
      options.relative_tolerance = 1e-12;
      Eigen::VectorXd x = Eigen::VectorXd::Zero(a.num_rows());
      const PcgSummary with = SolvePcg(a, jacobi, rhs, options, &x);
      EXPECT_TRUE(with.converged);
      EXPECT_LE(RelativeError(x, expected), 1e-8)
          << "pcg:   " << x.transpose() << "\ndense: " << expected.transpose();
      Eigen::VectorXd x_plain;
      const PcgSummary without =
          SolvePcg(a, IdentityOperator(a.num_rows()), rhs, options, &x_plain);
      // The badly scaled rows make the preconditioner worth it.
      EXPECT_LT(with.iterations, without.iterations);
    }
  }
}

TEST(Pcg, IterationCapIsRespected) {
  const BlockSparseMatrix a = RandomSpdMatrix(3, 3, 40);
  const Eigen::VectorXd rhs = RandomVector(3, a.num_rows());
  PcgOptions options;
  options.relative_tolerance = 1e-15;
  for (int cap : {0, 1, 3, 7}) {
    options.max_iterations = cap;
    Eigen::VectorXd x;
    const PcgSummary summary = SolvePcg(a, IdentityOperator(a.num_rows()), rhs, options, &x);
    EXPECT_EQ(summary.iterations, cap);
    EXPECT_FALSE(summary.converged);
    EXPECT_GT(summary.relative_residual, 1e-15);
  }
}

TEST(Pcg, ExactInitialGuessAndZeroRightHandSideNeedNoIteration) {
  const BlockSparseMatrix a = RandomSpdMatrix(4, 3, 10);
  const Eigen::VectorXd rhs = RandomVector(4, a.num_rows());
  PcgOptions options;
  options.relative_tolerance = 1e-8;
  Eigen::VectorXd x = a.ToDense().ldlt().solve(rhs);
  PcgSummary summary = SolvePcg(a, IdentityOperator(a.num_rows()), rhs, options, &x);
  EXPECT_TRUE(summary.converged);
  EXPECT_EQ(summary.iterations, 0);

  x = Eigen::VectorXd::Ones(a.num_rows());
  summary = SolvePcg(a, IdentityOperator(a.num_rows()), Eigen::VectorXd::Zero(a.num_rows()),
                     options, &x);
  EXPECT_TRUE(summary.converged);
  EXPECT_EQ(summary.iterations, 0);
  EXPECT_EQ(x, Eigen::VectorXd::Zero(a.num_rows()));
}

TEST(Pcg, IndefiniteMatrixStopsWithoutConverging) {
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(4, 4);
  a.diagonal() << 1.0, -1.0, 2.0, -3.0;
  const Eigen::VectorXd rhs = Eigen::VectorXd::Ones(4);  // p^T A p = -1 on the first step
  PcgOptions options;
  Eigen::VectorXd x;
  const PcgSummary summary = SolvePcg(DenseOperator(a), IdentityOperator(4), rhs, options, &x);
  EXPECT_FALSE(summary.converged);
  EXPECT_LT(summary.iterations, options.max_iterations);
  EXPECT_TRUE(x.allFinite());
}

// The energy test (truncated Newton): the A-norm error left at the stop is
// what the quadratic model still misses; it must be below the tolerance
// (the estimate i g_i is conservative on these well-conditioned systems),
// cost fewer iterations than the residual test, and stay off at 0.
TEST(Pcg, EnergyTestStopsWithTheMissedModelDecreaseBelowTheTolerance) {
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    const BlockSparseMatrix a = RandomSpdMatrix(seed + 70, 3, 200);
    const Eigen::VectorXd rhs = RandomVector(seed + 3000, a.num_rows());
    const Eigen::MatrixXd dense = a.ToDense();
    const Eigen::VectorXd exact = dense.ldlt().solve(rhs);
    const double full_decrease = rhs.dot(exact);  // |x*|_A^2, the whole model decrease
    // Without a preconditioner: enough iterations for the test to matter.
    const IdentityOperator jacobi(a.num_rows());
    PcgOptions options;
    options.max_iterations = 10 * a.num_rows();
    options.relative_tolerance = 1e-12;
    Eigen::VectorXd x_full;
    const PcgSummary full = SolvePcg(a, jacobi, rhs, options, &x_full);
    ASSERT_TRUE(full.converged);
    EXPECT_FALSE(full.truncated);
    int previous_iterations = full.iterations;
    for (const double fraction : {1e-8, 1e-5, 1e-3}) {
      options.energy_tolerance = fraction * full_decrease;
      Eigen::VectorXd x;
      const PcgSummary summary = SolvePcg(a, jacobi, rhs, options, &x);
      const Eigen::VectorXd error = x - exact;
      const double missed = error.dot(dense * error);
      EXPECT_TRUE(summary.truncated) << fraction;
      EXPECT_GE(summary.iterations, 10);  // the test's first iteration
      EXPECT_FALSE(summary.converged);
      EXPECT_LE(missed, options.energy_tolerance) << fraction;
      // Looser tolerance, fewer iterations; never more than the full solve.
      EXPECT_LE(summary.iterations, previous_iterations) << fraction;
      previous_iterations = summary.iterations;
    }
    EXPECT_LT(previous_iterations, full.iterations * 2 / 3);
    // Whatever the absolute tolerance, not before iteration 10.
    options.energy_tolerance = 1e300;
    Eigen::VectorXd x;
    const PcgSummary huge = SolvePcg(a, jacobi, rhs, options, &x);
    EXPECT_GE(huge.iterations, 10);
  }
}

TEST(Pcg, OptionsAreValidated) {
  PcgOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.max_iterations = -1;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  EXPECT_NE(options.Validate().message().find("max_iterations"), std::string::npos);
  options.max_iterations = 5;
  options.relative_tolerance = 0.0;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  EXPECT_NE(options.Validate().message().find("relative_tolerance"), std::string::npos);
  options.relative_tolerance = 1e-8;
  options.energy_tolerance = -1.0;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  EXPECT_NE(options.Validate().message().find("energy_tolerance"), std::string::npos);
}

}  // namespace
}  // namespace graphslam::core
