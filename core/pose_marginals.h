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
// THREAD SAFETY: not thread-safe (CHOLMOD's workspace). ALLOCATION: the factor
// (O(nnz(L))) in Factorize; an n x 3*batch dense block per batch.
#pragma once

#include <Eigen/Core>
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

  int num_rows() const;
  int block_size() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace graphslam::core
