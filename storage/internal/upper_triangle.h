// Symmetric N x N matrices from their upper triangle, row first (the g2o and
// iSAM layout: a11 a12 .. a1N a22 .. aNN, N (N + 1) / 2 numbers), and the
// iSAM square-root form Omega = S^T S with S upper triangular.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Core>

namespace graphslam::storage::internal {

template <int N>
Eigen::Matrix<double, N, N> SymmetricFromUpper(const double* upper) {
  Eigen::Matrix<double, N, N> m;
  int k = 0;
  for (int r = 0; r < N; ++r)
    for (int c = r; c < N; ++c) m(r, c) = m(c, r) = upper[k++];
  return m;
}

template <int N>
Eigen::Matrix<double, N, N> UpperFromRowFirst(const double* upper) {
  Eigen::Matrix<double, N, N> m = Eigen::Matrix<double, N, N>::Zero();
  int k = 0;
  for (int r = 0; r < N; ++r)
    for (int c = r; c < N; ++c) m(r, c) = upper[k++];
  return m;
}

template <typename Matrix>
bool IsPositiveDefiniteMatrix(const Matrix& m) {
  if (!m.allFinite()) return false;
  Eigen::LLT<Matrix> llt(m);
  return llt.info() == Eigen::Success;
}

}  // namespace graphslam::storage::internal
