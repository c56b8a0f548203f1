// BlockJacobiPreconditioner against dense inverses of the diagonal blocks.
#include "core/block_jacobi_preconditioner.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"

namespace graphslam::core {
namespace {

BlockSparseMatrix RandomMatrixWithSpdDiagonal(uint32_t seed, int b, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i + 1 < n; ++i) pairs.emplace_back(i, i + 1);
  BlockSparseMatrix m = BlockSparseMatrix::FromPattern(b, n, pairs);
  auto random = [&] {
    Eigen::MatrixXd r(b, b);
    for (int a = 0; a < b; ++a)
      for (int c = 0; c < b; ++c) r(a, c) = value(rng);
    return r;
  };
  for (const auto& [i, k] : pairs) EXPECT_TRUE(m.AddBlock(i, k, random()));
  for (int i = 0; i < n; ++i) {
    const Eigen::MatrixXd r = random();
    EXPECT_TRUE(m.AddBlock(i, i, r * r.transpose() + 0.1 * Eigen::MatrixXd::Identity(b, b)));
  }
  return m;
}

TEST(BlockJacobiPreconditioner, AppliesTheInverseOfTheBlockDiagonal) {
  for (int b : {1, 3, 6, 7}) {  // 7 takes the dynamic-size fallback
    for (uint32_t seed = 1; seed <= 3; ++seed) {
      SCOPED_TRACE(testing::Message() << "block size " << b << ", seed " << seed);
      const int n = seed == 3 ? 2 * BlockSparseMatrix::kMinBlockRowsForParallel : 12;
      const BlockSparseMatrix a = RandomMatrixWithSpdDiagonal(seed, b, n);
      BlockJacobiPreconditioner jacobi;
      ASSERT_TRUE(jacobi.Update(a).ok());
      EXPECT_EQ(jacobi.num_rows(), a.num_rows());
      const Eigen::MatrixXd dense = a.ToDense();
      Eigen::MatrixXd block_inverse = Eigen::MatrixXd::Zero(a.num_rows(), a.num_rows());
      for (int i = 0; i < n; ++i) {
        block_inverse.block(i * b, i * b, b, b) = dense.block(i * b, i * b, b, b).inverse();
      }
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> value(-1.0, 1.0);
      Eigen::VectorXd x(a.num_rows()), y0(a.num_rows());
      for (int j = 0; j < a.num_rows(); ++j) {
        x[j] = value(rng);
        y0[j] = value(rng);
      }
      Eigen::VectorXd y = y0;
      jacobi.RightMultiplyAndAccumulate(x.data(), y.data());
      const Eigen::VectorXd expected = y0 + block_inverse * x;
      // Relative 1e-10: blocks have condition numbers up to ~1e3.
      EXPECT_LE((y - expected).norm(), 1e-10 * expected.norm())
          << "jacobi: " << y.transpose() << "\ndense:  " << expected.transpose();
      // Stored inverses are exactly symmetric.
      const double* inverse = jacobi.InverseBlock(n - 1);
      for (int r = 0; r < b; ++r)
        for (int c = 0; c < b; ++c) EXPECT_EQ(inverse[r * b + c], inverse[c * b + r]);
    }
  }
}

TEST(BlockJacobiPreconditioner, NonPositiveDefiniteBlockIsNamedAndStateIsKept) {
  const BlockSparseMatrix good = RandomMatrixWithSpdDiagonal(5, 3, 6);
  BlockJacobiPreconditioner jacobi;
  ASSERT_TRUE(jacobi.Update(good).ok());
  const std::vector<double> before(jacobi.InverseBlock(0), jacobi.InverseBlock(0) + 9);

  BlockSparseMatrix bad = RandomMatrixWithSpdDiagonal(5, 3, 6);
  Eigen::VectorXd shift = Eigen::VectorXd::Zero(bad.num_rows());
  shift[4 * 3 + 1] = -1e3;  // block row 4 becomes indefinite
  bad.AddToDiagonal(shift);
  const Status status = jacobi.Update(bad);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();
  EXPECT_NE(status.message().find("block row 4"), std::string::npos) << status.ToString();
  EXPECT_NE(status.message().find("not positive definite"), std::string::npos)
      << status.ToString();
  const std::vector<double> after(jacobi.InverseBlock(0), jacobi.InverseBlock(0) + 9);
  EXPECT_EQ(before, after);
}

}  // namespace
}  // namespace graphslam::core
