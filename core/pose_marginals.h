// PoseMarginals: selected blocks of the marginal covariance of the reduced
// GraphSLAM unknowns, Sigma = S^{-1} (paper Table 5 "Sigma_0:t"), without ever
// forming the full inverse.
//
//   P S P^T = L L^T (CHOLMOD supernodal, AMD), then for a batch of blocks
//   {b_1..b_K}:  X = S^{-1} [E_b1 ... E_bK]   (3K right-hand sides at once)
//   so X's columns 3i..3i+2 are Sigma_{:, b_i}: every Sigma_{q, b_i}.
// ForEachColumnBlock hands each requested block's n x 3 column strip to the
// caller and forgets it, so memory is O(n * 3 * batch), and the cost is one
// multi-column triangular solve pair per batch: O(nnz(L) * 3K). A caller that
// needs Sigma_pq for pairs of blocks (the correspondence test,
// core/correspondence_test.h) requests only the blocks its tests touch.
//
// Why not Takahashi's sparse inverse subset: it yields Sigma only on the
// pattern of L, and a correspondence test between two traversals of one place
// needs Sigma_pq for poses far apart in time, which are not in that pattern
// until the merge is made.
//
// Whitened sparse columns (what the association driver uses): for a B that is
// nonzero only in a few block rows (a feature's gains Gamma, 2 columns),
//   y = L^{-1} P B,   so   B_1^T S^{-1} B_2 = y_1^T y_2
// for any two such B. y is nonzero only on the reach of B's rows in L: the
// union of their paths up the elimination tree to the root (Gilbert; Davis,
// "Direct Methods for Sparse Linear Systems" 3.2), and the forward solve
// touches only the columns of L on that reach. The ordering is METIS nested
// dissection, which keeps the elimination tree shallow: O(log n) separators
// for a pose chain, O(sqrt n) rows on a path for a planar graph (AMD gives a
// path graph a chain of depth n: y would be dense). One sparse solve per
// feature plus one sparse dot product per candidate pair replaces a dense
// column solve per pose.
//
// THREAD SAFETY: Factorize and ForEachColumnBlock are not thread-safe
// (CHOLMOD's workspace); Whiten is const and thread-safe with one
// WhitenWorkspace per thread. ALLOCATION: the factor (O(nnz(L))) in
// Factorize; an n x 3*batch dense block per batch; a workspace of O(n).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/status.h"

namespace graphslam::core {

class PoseMarginals {
 public:
  PoseMarginals();
  ~PoseMarginals();
  PoseMarginals(const PoseMarginals&) = delete;
  PoseMarginals& operator=(const PoseMarginals&) = delete;

  // Factorizes S (symmetric positive definite). Numerical if it is not.
  [[nodiscard]] Status Factorize(const BlockSparseMatrix& s);

  // Calls visit(block, columns) for every entry of `blocks` (distinct block
  // indices, any order), where columns = Sigma_{:, block} (num_rows x b).
  // The reference is valid only during the call. `batch` blocks are solved
  // together.
  [[nodiscard]] Status ForEachColumnBlock(
      const std::vector<int>& blocks, int batch,
      const std::function<void(int block, const Eigen::Ref<const Eigen::MatrixXd>& columns)>&
          visit) const;

  // y = L^{-1} P B restricted to its nonzero rows (positions in the
  // permuted order, ascending), for B with two columns.
  struct WhitenedColumns {
    std::vector<int32_t> rows;
    std::vector<double> values;  // 2 per row, row-major
  };
  struct WhitenWorkspace {
    std::vector<uint32_t> mark;
    uint32_t stamp = 0;
    std::vector<double> x;  // 2 per row
    std::vector<int32_t> stack;
  };
  // B = sum_i E_{blocks[i]} values[i] (3 x 2 blocks; block_size() must be 3;
  // a block may repeat). `workspace` is the caller's, one per thread.
  [[nodiscard]] Status Whiten(const std::vector<int32_t>& blocks,
                              const std::vector<Eigen::Matrix<double, 3, 2>>& values,
                              WhitenedColumns* out, WhitenWorkspace* workspace) const;
  // y_a^T y_b = B_a^T S^{-1} B_b (2 x 2).
  static Eigen::Matrix2d Dot(const WhitenedColumns& a, const WhitenedColumns& b);

  int num_rows() const;
  int block_size() const;
  // Sum of the rows of the elimination-tree path of every row / num_rows
  // (the mean number of rows Whiten gives one unit vector), for reports.
  double MeanReach() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace graphslam::core
