// Subgraph (spanning-tree) preconditioner for the reduced pose system, after
//   F. Dellaert, J. Carlson, V. Ila, K. Ni, C. E. Thorpe, "Subgraph-
//   preconditioned conjugate gradients for large scale SLAM", IROS 2010.
//
// The block graph of A (one vertex per pose block, one edge per nonzero
// off-diagonal block A_ik) is split into a spanning forest T and the rest.
// The preconditioner keeps T exactly:
//
//   M_ii = A_ii (+ C_i, see below),   M_ik = A_ik if (i,k) in T, else 0
//   y += M^{-1} x
//
// T is the maximum-weight spanning forest (Kruskal) for the scale-free
// coupling  w_ik = ||A_ik||_F / sqrt(||A_ii||_F ||A_kk||_F),  so the odometry
// chain -- the strongest couplings of a pose graph -- is in T, and where a
// loop closure is stronger than odometry the closure is kept instead.
//
// A tree has no fill: eliminating leaves first (a post-order of each tree),
// the block LDL^T factor has exactly the tree's blocks,
//
//   P_i = M_ii - sum_{children c of i} A_ic P_c^{-1} A_ci      (pivot)
//   L_{p(i), i} = A_{p(i), i} P_i^{-1}                          (p = parent)
//
// and M^{-1} x is one forward and one backward sweep over the tree:
//   z = x;  for i in post-order:  z_p(i) -= L_{p(i),i} z_i
//   for i in reverse post-order:  y_i = P_i^{-1} z_i - L_{p(i),i}^T y_p(i)
// O(n b^2) per application and O(n b^3) per Update (the brief suggested
// CHOLMOD for this exact factor; for a tree it does the same work, but its
// solve allocates its result vector and works on 3x3 supernodes, while this
// sweep stores everything in post-order for sequential memory access).
//
// Positive definiteness. For a pure pose graph A = sum_e A_e with every edge
// term A_e positive semidefinite; M = sum_{e in T} A_e + sum_{e not in T}
// blockdiag(A_e) is then positive definite whenever the tree part with the
// anchor is. After features are eliminated A is a sum of dense Schur cliques
// and dropping blocks of a clique can make M indefinite. When a pivot P_i is
// not positive definite, Update therefore retries with diagonal compensation
// (Axelsson's diagonally compensated reduction): for each dropped block B =
// A_ik, C_i += ||B||_F I and C_k += ||B||_F I. Then M - A = sum over dropped
// blocks of [[c I, -B], [-B^T, c I]] with c >= ||B||_2, which is positive
// semidefinite, so M >= A > 0 always factors. compensated() reports it.
//
// THREAD SAFETY: RightMultiplyAndAccumulate is const; concurrent calls are
// correct but serialized (one scratch vector guarded by a mutex; the sweeps
// are sequential anyway). Update must not run concurrently with anything else.
//
// ALLOCATION: Update allocates O(nonzero blocks) for the forest search and
// O(n b^2) for the factor. RightMultiplyAndAccumulate never allocates.
#pragma once

#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/linear_operator.h"
#include "core/status.h"

namespace graphslam::core {

class SubgraphPreconditioner : public LinearOperator {
 public:
  SubgraphPreconditioner();
  ~SubgraphPreconditioner() override;

  // Chooses the forest (on the first call and whenever the pattern of `a`
  // changes size) and factors M. Returns Status::Numerical naming the block
  // row if a diagonal block of A is not finite or even the compensated M does
  // not factor (A is then not positive definite); the previous state is kept.
  [[nodiscard]] Status Update(const BlockSparseMatrix& a);

  int num_rows() const override { return num_blocks_ * block_size_; }

  // y += M^{-1} x. Requires a successful Update.
  void RightMultiplyAndAccumulate(const double* x, double* y) const override;

  // Off-diagonal blocks kept in the forest (= blocks - trees).
  int num_tree_edges() const { return num_tree_edges_; }
  // Whether the last Update needed the diagonal compensation.
  bool compensated() const { return compensated_; }

  // The forest, for a checkpoint (core/pcg_solver_state.h): block rows in
  // elimination order, and each block row's parent block row (-1: a root).
  // Both empty before the first Update.
  const std::vector<int>& forest_order() const { return order_; }
  const std::vector<int>& forest_parent() const { return parent_block_; }

  // Takes over a forest saved from forest_order() / forest_parent() for
  // matrices with the pattern of `pattern`, so that the next Update factors
  // it instead of choosing one from its values (a resumed solve must use the
  // forest of the interrupted one). InvalidArgument, with the state
  // unchanged, if the forest does not fit the pattern: sizes, a permutation,
  // parents eliminated after their children, tree edges that are blocks.
  [[nodiscard]] Status SetForest(const BlockSparseMatrix& pattern, const std::vector<int>& order,
                                 const std::vector<int>& parent_block);

 private:
  // Factors M into `out` with or without compensation; false if a pivot is
  // not positive definite (then *failed_block is its block row).
  bool Factor(const BlockSparseMatrix& a, bool compensate, std::vector<double>* pivot_inverse,
              std::vector<double>* lower, int* failed_block) const;
  void ChooseForest(const BlockSparseMatrix& a);

  int block_size_ = 0;
  int num_blocks_ = 0;
  int num_tree_edges_ = 0;
  int64_t pattern_blocks_ = -1;  // nonzero blocks of the A the forest was chosen for
  bool compensated_ = false;
  // Post-order: order_[t] is the block row eliminated t-th; parent_[t] is the
  // post-order position of its parent (> t), or -1 for a root.
  std::vector<int> order_;
  std::vector<int> parent_;
  std::vector<int> parent_block_;  // block row of the parent, -1 for a root
  std::vector<double> pivot_inverse_;  // P^{-1}, b x b row-major per position
  std::vector<double> lower_;          // L_{p,i}, b x b row-major per position
  mutable std::mutex mutex_;
  mutable std::vector<double> scratch_;  // GUARDED_BY(mutex_), n entries, post-order
};

}  // namespace graphslam::core
