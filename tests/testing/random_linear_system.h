// Random linear systems for the linear-algebra tests:
// seeded property tests against dense reference math.
#pragma once

#include <Eigen/Dense>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "core/block_sparse_matrix.h"

namespace graphslam::testing {

using core::BlockSparseMatrix;

// Random SPD block matrix: a chain plus random pairs with random blocks
// scaled by sqrt(s_i s_k), row scales s_i in 10^-2..10^2, and diagonal blocks
// that make it strictly diagonally dominant (hence SPD). The row scales make
// plain CG slow (condition ~1e4) and block-Jacobi effective.
inline BlockSparseMatrix RandomSpdMatrix(uint32_t seed, int b, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::uniform_int_distribution<int> index(0, n - 1);
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i + 1 < n; ++i) pairs.emplace_back(i, i + 1);
  for (int e = 0; e < n; ++e) {
    const int i = index(rng), k = index(rng);
    if (i != k) pairs.emplace_back(i, k);
  }
  BlockSparseMatrix m = BlockSparseMatrix::FromPattern(b, n, pairs);
  std::vector<double> scale(n);
  for (int i = 0; i < n; ++i) scale[i] = std::pow(10.0, 2.0 * value(rng));
  for (const auto& [i, k] : pairs) {
    Eigen::MatrixXd block(b, b);
    for (int r = 0; r < b; ++r)
      for (int c = 0; c < b; ++c) block(r, c) = value(rng) * std::sqrt(scale[i] * scale[k]);
    EXPECT_TRUE(m.AddBlock(i, k, block));
  }
  const Eigen::MatrixXd dense = m.ToDense();
  const Eigen::VectorXd row_sums = dense.cwiseAbs().rowwise().sum();
  for (int i = 0; i < n; ++i) {
    Eigen::MatrixXd r(b, b);
    for (int a = 0; a < b; ++a)
      for (int c = 0; c < b; ++c) r(a, c) = value(rng);
    Eigen::MatrixXd diagonal = scale[i] * r * r.transpose();
    for (int a = 0; a < b; ++a) {
      diagonal(a, a) += row_sums[i * b + a] + scale[i] * (0.1 + diagonal.row(a).cwiseAbs().sum());
    }
    EXPECT_TRUE(m.AddBlock(i, i, diagonal));
  }
  return m;
}

inline Eigen::VectorXd RandomVector(uint32_t seed, int n) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = value(rng);
  return v;
}

inline double RelativeError(const Eigen::VectorXd& actual, const Eigen::VectorXd& expected) {
  return (actual - expected).norm() / expected.norm();
}

}  // namespace graphslam::testing
