// Block-Jacobi preconditioner: M = blockdiag(A_00, A_11, ...), applied as
//
//   y_i += A_ii^{-1} x_i      for every block row i
//
// Each b x b diagonal block of the symmetric positive definite A is inverted
// through its Cholesky factor (A_ii = L L^T, A_ii^{-1} = L^{-T} L^{-1}) in
// Update(); the product is then a block-diagonal matrix-vector product. For
// the reduced pose system of GraphSLAM this captures each pose's own
// information, the cheapest preconditioner that makes PCG usable
// (Ceres' BlockJacobiPreconditioner).
//
// THREAD SAFETY: RightMultiplyAndAccumulate is const and may run concurrently;
// Update must not run concurrently with anything else on the same object.
//
// ALLOCATION: Update allocates only when the matrix dimensions change (two
// buffers of num_block_rows * b^2 doubles: the inverses are computed into a
// spare buffer and swapped in, so a failed Update leaves the previous
// preconditioner intact). RightMultiplyAndAccumulate never allocates.
#pragma once

#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/linear_operator.h"
#include "core/status.h"

namespace graphslam::core {

class BlockJacobiPreconditioner : public LinearOperator {
 public:
  BlockJacobiPreconditioner() = default;

  // Inverts every diagonal block of `a`. Returns Status::Numerical naming the
  // block row if a block is not positive definite or not finite; the previous
  // state is then kept.
  [[nodiscard]] Status Update(const BlockSparseMatrix& a);

  int num_rows() const override { return num_block_rows_ * block_size_; }
  int block_size() const { return block_size_; }

  // y += M^{-1} x. Requires a successful Update. Parallel over block rows
  // like BlockSparseMatrix (bit-exact equal to serial).
  void RightMultiplyAndAccumulate(const double* x, double* y) const override;

  // Row-major b x b inverse of diagonal block i.
  const double* InverseBlock(int i) const;

 private:
  void MultiplyRows(int begin, int end, const double* x, double* y) const;

  int block_size_ = 0;
  int num_block_rows_ = 0;
  std::vector<double> inverse_;  // num_block_rows_ * b * b, row-major blocks
  std::vector<double> spare_;    // Update's output before it is swapped in
};

}  // namespace graphslam::core
