// BlockSparseMatrix: a symmetric square matrix made of uniform b x b blocks,
// stored in block-CSR with BOTH triangles present (full storage).
//
//          block col k ->
//   A = [ A_00  A_01  .    ]     A_ki = A_ik^T,  every A_ii is in the pattern
//       [ A_10  A_11  A_12 ]     row_start_[i] .. row_start_[i+1]-1 : blocks of row i
//       [  .    A_21  A_22 ]     block_cols_[j] sorted ascending within a row
//                                values_[j*b*b .. (j+1)*b*b) : block j, row-major
//
// The block size b is chosen at run time (3 for planar poses, 6 for 3-D poses).
// The sparsity pattern is fixed at construction (FromPattern); values are then
// zeroed and accumulated many times (AddBlock, AddToDiagonal). This is the
// reduced pose system S of GraphSLAM (Thrun & Montemerlo 2006, Table 3) after
// the features are eliminated. Full storage costs twice the memory of one
// triangle but makes the product y += A x a pure row loop: every output block
// row is written by exactly one task, so the TBB-parallel product is bit-exact
// equal to the serial one. ToSparseUpper() exports the upper triangle for
// CHOLMOD. After Ceres' BlockSparseMatrix / CompressedRowSparseMatrix.
//
// THREAD SAFETY: const methods may be called concurrently. AddBlock and
// MutableBlock writes to distinct blocks may run concurrently; AddBlock(i,k)
// also writes (k,i), so concurrent callers must own disjoint block pairs.
//
// ALLOCATION: FromPattern allocates O(pairs + blocks * b^2). SetZero, AddBlock,
// MutableBlock, AddToDiagonal and RightMultiplyAndAccumulate never allocate.
// Diagonal(), ToDense() and ToSparseUpper() return new objects.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/linear_operator.h"

namespace graphslam::core {

class BlockSparseMatrix : public LinearOperator {
 public:
  // Products over at least this many block rows run as a tbb::parallel_for.
  static constexpr int kMinBlockRowsForParallel = 256;

  // The pattern holds every (i,k) and (k,i) of `pairs` plus all diagonal blocks
  // (i,i). Pairs may come in any order and repeat. Values start at zero.
  // Requires block_size >= 1, num_block_rows >= 0 and 0 <= i,k < num_block_rows.
  static BlockSparseMatrix FromPattern(int block_size, int num_block_rows,
                                       std::vector<std::pair<int, int>> pairs);

  BlockSparseMatrix() = default;

  int block_size() const { return block_size_; }
  int num_block_rows() const { return num_block_rows_; }
  int num_rows() const override { return num_block_rows_ * block_size_; }
  int64_t num_nonzero_blocks() const { return static_cast<int64_t>(block_cols_.size()); }

  // Sets every stored value to zero; the pattern is kept.
  void SetZero();

  // A_ik += block and, if i != k, A_ki += block^T. For i == k the block is
  // added once; the caller passes a symmetric block. Returns false (and
  // changes nothing) if (i,k) is not in the pattern. block must be b x b.
  bool AddBlock(int i, int k, const Eigen::Ref<const Eigen::MatrixXd>& block);

  // Row-major b x b values of block (i,k), or nullptr if not in the pattern.
  // Writing through MutableBlock(i,k) does not update (k,i): keep them equal.
  double* MutableBlock(int i, int k);
  const double* Block(int i, int k) const;

  // A_jj += d_j for every scalar row j (Levenberg-Marquardt damping).
  // d has num_rows() entries.
  void AddToDiagonal(const Eigen::VectorXd& d);
  // The scalar diagonal (num_rows() entries).
  Eigen::VectorXd Diagonal() const;

  // y += A x. Parallel over block rows when num_block_rows() >=
  // kMinBlockRowsForParallel; each block row is always computed by one task
  // with the same operation order, so the result equals the serial one bit
  // for bit.
  void RightMultiplyAndAccumulate(const double* x, double* y) const override;
  // The same product, always on the calling thread (for callers already
  // inside a parallel region, and as the reference in tests).
  void RightMultiplyAndAccumulateSerial(const double* x, double* y) const;

  Eigen::MatrixXd ToDense() const;
  // Column-major upper triangle including the diagonal, compressed, with
  // sorted row indices; the layout CHOLMOD reads with stype = +1.
  Eigen::SparseMatrix<double> ToSparseUpper() const;

  // The raw block-CSR arrays (see the picture above).
  const std::vector<int64_t>& row_start() const { return row_start_; }
  const std::vector<int>& block_cols() const { return block_cols_; }

 private:
  // Index of block (i,k) in block_cols_, or -1.
  int64_t FindBlock(int i, int k) const;
  void MultiplyRows(int begin, int end, const double* x, double* y) const;

  int block_size_ = 0;
  int num_block_rows_ = 0;
  std::vector<int64_t> row_start_;     // num_block_rows_ + 1
  std::vector<int> block_cols_;        // num_nonzero_blocks
  std::vector<int64_t> diagonal_;      // index of block (i,i) for each row i
  std::vector<double> values_;         // num_nonzero_blocks * b * b, row-major blocks
};

}  // namespace graphslam::core
