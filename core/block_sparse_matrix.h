// BlockSparseMatrix: a symmetric square matrix made of uniform b x b blocks,
// stored as its UPPER triangle (diagonal blocks included) in block-CSR, plus a
// transpose index that lists, for every block column, the strictly-upper
// blocks in it.
//
//          block col k ->
//   A = [ U_00  U_01  .    ]     A_ik = U_ik for i <= k,  A_ik = U_ki^T for i > k
//       [  .    U_11  U_12 ]     row_start_[i] .. row_start_[i+1]-1 : blocks (i, k >= i)
//       [  .     .    U_22 ]     block_cols_[j] ascending within a row; the first
//                                block of row i is the diagonal U_ii
//                                values_[j*b*b .. (j+1)*b*b) : block j, row-major
//   transpose index: col_start_[i] .. col_start_[i+1]-1 : the blocks (k < i, i),
//                    col_rows_[t] = k ascending, col_blocks_[t] = their j
//
// The block size b is chosen at run time (3 for planar poses, 6 for 3-D poses).
// The sparsity pattern is fixed at construction (FromPattern); values are then
// zeroed and accumulated many times (AddBlock, AddToDiagonal). This is the
// reduced pose system S of GraphSLAM (Thrun & Montemerlo 2006, Table 3) after
// the features are eliminated; at 10^6 poses it is the largest object of the
// streaming solve, so only one triangle is kept (about half the bytes of full
// storage, docs/out_of_core.md).
//
// The product y += A x is still a pure row loop: output block row i is
//   y_i += sum_{k<i} U_ki^T x_k  +  sum_{k>=i} U_ik x_k,
// the first sum read through the transpose index, both in ascending k, and it
// is computed by exactly one task. So the TBB-parallel product equals the
// serial one bit for bit for any thread count, and it performs the same
// operations in the same order as the former full storage did.
// ToSparseUpper() exports the upper triangle for CHOLMOD. After Ceres'
// BlockSparseMatrix / CompressedRowSparseMatrix.
//
// THREAD SAFETY: const methods may be called concurrently. AddBlock and
// MutableBlock writes to distinct blocks may run concurrently; AddBlock(i,k)
// and AddBlock(k,i) write the same stored block, so concurrent callers must
// own disjoint unordered pairs {i,k}.
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

  // The pattern holds every pair {i,k} of `pairs` (stored once, as
  // (min, max)) plus all diagonal blocks (i,i). Pairs may come in any order
  // and orientation and repeat. Values start at zero. Requires block_size >= 1,
  // num_block_rows >= 0, 0 <= i,k < num_block_rows and fewer than 2^31 stored
  // blocks.
  static BlockSparseMatrix FromPattern(int block_size, int num_block_rows,
                                       std::vector<std::pair<int, int>> pairs);

  BlockSparseMatrix() = default;

  int block_size() const { return block_size_; }
  int num_block_rows() const { return num_block_rows_; }
  int num_rows() const override { return num_block_rows_ * block_size_; }
  // Nonzero blocks of the symmetric matrix, both triangles counted (what a
  // full-storage format would hold): 2 * num_stored_blocks() - num_block_rows().
  int64_t num_nonzero_blocks() const {
    return 2 * num_stored_blocks() - static_cast<int64_t>(num_block_rows_);
  }
  // Blocks actually stored: the upper triangle including the diagonal.
  int64_t num_stored_blocks() const { return static_cast<int64_t>(block_cols_.size()); }

  // Sets every stored value to zero; the pattern is kept.
  void SetZero();

  // A_ik += block (and so A_ki += block^T). For i <= k the block is added to
  // the stored U_ik; for i > k its transpose is added to the stored U_ki. For
  // i == k the block is added once; the caller passes a symmetric block.
  // Returns false (and changes nothing) if {i,k} is not in the pattern.
  // block must be b x b.
  bool AddBlock(int i, int k, const Eigen::Ref<const Eigen::MatrixXd>& block);

  // Row-major b x b values of the stored block U_ik, for i <= k only; nullptr
  // if i > k (the lower triangle is not stored: read U_ki and transpose) or if
  // (i,k) is not in the pattern.
  double* MutableBlock(int i, int k);
  const double* Block(int i, int k) const;
  // Whether A_ik (equivalently A_ki) is in the pattern, any orientation.
  bool HasBlock(int i, int k) const;

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

  // Both triangles.
  Eigen::MatrixXd ToDense() const;
  // Column-major upper triangle including the diagonal, compressed, with
  // sorted row indices; the layout CHOLMOD reads with stype = +1.
  Eigen::SparseMatrix<double> ToSparseUpper() const;

  // The raw arrays (see the picture above). Block row i of the full matrix,
  // in ascending column order, is: U_{col_rows[t], i}^T for t in
  // [col_start[i], col_start[i+1]), then U_{i, block_cols[j]} for j in
  // [row_start[i], row_start[i+1]). StoredBlock(j) is the row-major U of
  // index j.
  const std::vector<int64_t>& row_start() const { return row_start_; }
  const std::vector<int>& block_cols() const { return block_cols_; }
  const std::vector<int64_t>& col_start() const { return col_start_; }
  const std::vector<int>& col_rows() const { return col_rows_; }
  const std::vector<int>& col_blocks() const { return col_blocks_; }
  const double* StoredBlock(int64_t j) const {
    return values_.data() + j * block_size_ * block_size_;
  }

 private:
  // Index of stored block (i,k), i <= k, in block_cols_, or -1.
  int64_t FindBlock(int i, int k) const;
  void MultiplyRows(int begin, int end, const double* x, double* y) const;

  int block_size_ = 0;
  int num_block_rows_ = 0;
  std::vector<int64_t> row_start_;  // num_block_rows_ + 1
  std::vector<int> block_cols_;     // num_stored_blocks; row_start_[i] is (i,i)
  std::vector<int64_t> col_start_;  // num_block_rows_ + 1
  std::vector<int> col_rows_;       // strictly-upper blocks, by column, rows ascending
  std::vector<int> col_blocks_;     // their index in block_cols_ (int: < 2^31 blocks)
  std::vector<double> values_;      // num_stored_blocks * b * b, row-major blocks
};

}  // namespace graphslam::core
