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
// The product does not use the transpose index; the preconditioners that
// walk a whole block row (subgraph compensation, incomplete Cholesky's fill
// pattern), the deflation's S W and ToSparseUpper (CHOLMOD) do (8 bytes per
// strictly-upper block against 72 + 4 of the block itself at b = 3).
//
// The block size b is chosen at run time (3 for planar poses, 6 for 3-D poses).
// The sparsity pattern is fixed at construction (FromPattern); values are then
// zeroed and accumulated many times (AddBlock, AddToDiagonal). This is the
// reduced pose system S of GraphSLAM (Thrun & Montemerlo 2006, Table 3) after
// the features are eliminated; at 10^6 poses it is the largest object of the
// streaming solve, so only one triangle is kept (about half the bytes of full
// storage, docs/out_of_core.md).
//
// The product y += A x reads every stored block once, in one sweep over the
// block rows (half the bytes of full storage, streamed in storage order):
//   for every stored U_ik (i <= k):  y_i += U_ik x_k,  and if i != k: y_k += U_ik^T x_i.
// The transposed half scatters into rows k >= i, so parallel tasks would
// collide. The rows are therefore split into a FIXED list of ranges
// [r0, r1) -- about kProductNonzerosPerRange stored scalars each, a function
// of the pattern only, never of the thread count -- and each range R writes
//   rows k in [r0, r1)   directly into y (only R writes them in the sweep),
//   rows k >= r1         into R's private accumulator: one slot per distinct
//                        row R reaches (the slot of each block precomputed),
//                        nearest rows first, at most 4 (r1 - r0) slots,
//   rows beyond those    nowhere: such a "far" block is read again later.
// On a pose system (poses couple to nearby poses plus loop closures) the
// slots are the band below the range and the loop-closure rows, far blocks
// occur only where a range reaches more than 4x its own rows, and all
// accumulators together hold at most 4 num_rows() doubles. After all ranges
// are swept, a second pass over the same ranges Q adds into each row k of Q:
// the slots for k of every range R < Q, in ascending R, then the far
// contributions U_ik^T x_i to Q's rows, in storage order (ascending i, then
// k). Every scalar of y thus sees a fixed sequence of operations, whichever
// task runs a range: the TBB product equals the serial one bit for bit for
// any number of threads. (It is not bit-identical to a row-by-row product:
// the summation order differs.)
// ToSparseUpper() exports the upper triangle for CHOLMOD. After Ceres'
// BlockSparseMatrix / CompressedRowSparseMatrix.
//
// THREAD SAFETY: const methods may be called concurrently. AddBlock and
// MutableBlock writes to distinct blocks may run concurrently; AddBlock(i,k)
// and AddBlock(k,i) write the same stored block, so concurrent callers must
// own disjoint unordered pairs {i,k}.
//
// ALLOCATION: FromPattern allocates O(pairs + blocks * b^2). SetZero, AddBlock,
// MutableBlock and AddToDiagonal never allocate; RightMultiplyAndAccumulate
// allocates only when called concurrently on the same matrix (the range
// accumulators are allocated with the matrix, O(num_rows()), and shared by
// one caller at a time; a concurrent caller gets its own).
// Diagonal(), ToDense() and ToSparseUpper() return new objects.
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <cstdint>
#include <mutex>
#include <utility>
#include <vector>

#include "core/linear_operator.h"

namespace graphslam::core {

class BlockSparseMatrix : public LinearOperator {
 public:
  // Loops over at least this many block rows run as a tbb::parallel_for
  // (the block-Jacobi preconditioner; the product splits by
  // kProductNonzerosPerRange instead).
  static constexpr int kMinBlockRowsForParallel = 256;
  // Stored scalar nonzeros per product range (1 MiB of values): big enough
  // that the per-range overhead is small, small enough that 10^5 poses give
  // dozens of ranges for the threads to share.
  static constexpr int64_t kProductNonzerosPerRange = int64_t{1} << 17;

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

  // y += A x (the sweep above). Parallel over the product ranges when there
  // is more than one; the result equals the serial one bit for bit.
  void RightMultiplyAndAccumulate(const double* x, double* y) const override;
  // The same product, always on the calling thread (for callers already
  // inside a parallel region, and as the reference in tests).
  void RightMultiplyAndAccumulateSerial(const double* x, double* y) const;

  // Re-splits the rows into product ranges of about stored_blocks_per_range
  // stored blocks (FromPattern uses kProductNonzerosPerRange / b^2). For tests
  // and benchmarks that want many ranges on a small matrix. Allocates.
  void PartitionForProduct(int64_t stored_blocks_per_range);
  int num_product_ranges() const { return static_cast<int>(range_start_.size()) - 1; }
  // Blocks whose transposed half finds no slot in their range's accumulator.
  int64_t num_far_blocks() const { return static_cast<int64_t>(far_blocks_.size()); }
  // Rows (slots) of all range accumulators together.
  int64_t num_accumulator_rows() const {
    return target_start_.empty() ? 0 : target_start_.back();
  }

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
  // The sweep of range r (its accumulator within acc), and the merge into
  // the rows of range q.
  void SweepRange(int r, const double* x, double* y, double* acc) const;
  void MergeRange(int q, const double* x, double* y, const double* acc) const;
  void Multiply(const double* x, double* y, bool parallel) const;

  // Window accumulators, shared by one product at a time. Copies get their
  // own (same size); the mutex is never copied.
  struct Scratch {
    Scratch() = default;
    Scratch(const Scratch& other) : values(other.values.size()) {}
    Scratch& operator=(const Scratch& other) {
      if (this != &other) values.assign(other.values.size(), 0.0);
      return *this;
    }
    std::mutex mutex;
    std::vector<double> values;
  };

  int block_size_ = 0;
  int num_block_rows_ = 0;
  std::vector<int64_t> row_start_;  // num_block_rows_ + 1
  std::vector<int> block_cols_;     // num_stored_blocks; row_start_[i] is (i,i)
  std::vector<int64_t> col_start_;  // num_block_rows_ + 1
  std::vector<int> col_rows_;       // strictly-upper blocks, by column, rows ascending
  std::vector<int> col_blocks_;     // their index in block_cols_ (int: < 2^31 blocks)
  std::vector<double> values_;      // num_stored_blocks * b * b, row-major blocks
  // The product ranges: range r is block rows [range_start_[r], range_start_[r+1]).
  std::vector<int> range_start_;
  // Range r's accumulator: slot t in [target_start_[r], target_start_[r+1])
  // collects row target_rows_[t] (ascending, all >= range_start_[r+1]), at
  // scratch offset t * b. Blocks (i, k) of r with k >= far_from_[r] are far.
  std::vector<int64_t> target_start_;
  std::vector<int> target_rows_;
  std::vector<int> far_from_;
  // The local slot of every accumulated block of range r, in sweep order, at
  // slots_[slot_start_[r] ..).
  std::vector<int64_t> slot_start_;
  std::vector<int> slots_;
  // For range q, the runs of slots [begin, end) of earlier ranges whose rows
  // lie in q, ascending range: merge_runs_[merge_start_[q] .. merge_start_[q+1]).
  struct MergeRun {
    int64_t begin = 0, end = 0;
  };
  std::vector<int64_t> merge_start_;
  std::vector<MergeRun> merge_runs_;
  // Far blocks sorted by (range of column k, row i, k): far_rows_ = i,
  // far_cols_ = k, far_blocks_ = their index j; those with k in range q at
  // [far_start_[q], far_start_[q+1]).
  std::vector<int64_t> far_start_;
  std::vector<int> far_rows_;
  std::vector<int> far_cols_;
  std::vector<int> far_blocks_;
  mutable Scratch scratch_;
};

}  // namespace graphslam::core
