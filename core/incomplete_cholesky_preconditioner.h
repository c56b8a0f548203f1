// Incomplete Cholesky preconditioner for the reduced pose system: a limited-
// memory incomplete factor L of the scaled, AMD-permuted A, applied as
//
//   S P A P^T S  ~  L L^T                       (Update)
//   y += M^{-1} x = P^T S L^{-T} L^{-1} S P x   (RightMultiplyAndAccumulate)
//
//   P  fill-reducing permutation (approximate minimum degree on the scalar
//      pattern handed to Eigen, see G below)
//   S  diagonal scaling, S_jj = ||A_{:,j}||_2^{-1/2}, so S P A P^T S has
//      entries of order one
//   L  lower triangular; column j keeps only the p_j entries of largest
//      magnitude among the original entries and the fill, where p_j is the
//      number of off-diagonal entries of column j of the pattern G:
//        G = block pattern of A^(fill_levels + 1)  (blocks within
//            fill_levels + 1 edges of each other in the pose graph)
//      Entries of G that A lacks are passed as explicit zeros; Eigen counts
//      them, so they are a memory budget that goes to the largest fill
//      anywhere in the column. nnz(L) = nnz(tril(G)) exactly.
//
// Block-Jacobi (core/block_jacobi_preconditioner.h) only sees each pose's own
// information; on a loop-closing pose graph the error left by PCG is smooth
// along the trajectory and block-Jacobi needs O(graph diameter) iterations to
// propagate it. The incomplete factor couples neighbouring poses through L,
// which removes much of that long-range error per iteration.
// Against block-Jacobi, level 0 halves the iteration count and level 1
// quarters it at twice the memory of A's triangle; hence the default 1
// (figures: docs/tuning.md).
//
// The factorization is Eigen's Eigen::IncompleteCholesky<double, Eigen::Lower,
// Eigen::AMDOrdering<int>> (Eigen 3.4), which follows
//   C.-J. Lin and J. J. More, "Incomplete Cholesky factorizations with limited
//   memory", SIAM J. Sci. Comput. 21(1), pp. 24-45, 1999 (ICFS),
// with ICFS's memory parameter p fixed at 0: Eigen 3.4 exposes no fill or
// drop-tolerance setter for this class (those exist only on IncompleteLUT),
// hence the explicit-zero budget above. Its one knob is the initial diagonal
// shift sigma:
//   beta = min_j (S P A P^T S)_jj; the first attempt uses shift 0 if beta > 0,
//   else sigma - beta; whenever a pivot is <= 0 the shift becomes
//   max(sigma, 2 * shift) and the factorization restarts, at most 10 attempts.
// A non-positive or non-finite diagonal of A is rejected before Eigen is
// called (A is then not positive definite, and Eigen would silently shift it),
// and the finished factor is checked for non-finite values, which Eigen does
// not detect.
//
// THREAD SAFETY: RightMultiplyAndAccumulate is const and may be called
// concurrently; the triangular solves need one n-vector of scratch, which is
// owned by the factor and guarded by a mutex, so concurrent calls are correct
// but run one at a time (a triangular solve is sequential anyway). Update must
// not run concurrently with anything else on the same object.
//
// ALLOCATION: Update allocates: the pattern G and the lower triangle of A on
// it, the AMD ordering, Eigen's working copies (O(nnz(A))), and the new factor, which is
// built beside the current one and swapped in only on success, so a failed
// Update leaves the previous preconditioner intact.
// RightMultiplyAndAccumulate never allocates.
#pragma once

#include <cstdint>
#include <memory>

#include "core/block_sparse_matrix.h"
#include "core/linear_operator.h"
#include "core/status.h"

namespace graphslam::core {

struct IncompleteCholeskyOptions {
  // Eigen's sigma (setInitialShift): the first diagonal shift tried, on the
  // scaled matrix (diagonal entries <= 1), when a pivot breaks down. Eigen's
  // default. Raise it if Update reports a breakdown after 10 shifts.
  double initial_shift = 1e-3;

  // Memory budget of L: the block pattern of A^(fill_levels + 1) (see the
  // picture above). 0 gives Eigen's plain limited-memory factor, nnz(L) =
  // nnz(tril A); each level widens it by one more ring of neighbouring poses.
  int fill_levels = 1;
  static constexpr int kMaxFillLevels = 4;

  // InvalidArgument naming the field unless initial_shift is positive and
  // finite and 0 <= fill_levels <= kMaxFillLevels.
  [[nodiscard]] Status Validate() const;
};

class IncompleteCholeskyPreconditioner : public LinearOperator {
 public:
  explicit IncompleteCholeskyPreconditioner(const IncompleteCholeskyOptions& options = {});
  ~IncompleteCholeskyPreconditioner() override;
  IncompleteCholeskyPreconditioner(IncompleteCholeskyPreconditioner&&) noexcept;
  IncompleteCholeskyPreconditioner& operator=(IncompleteCholeskyPreconditioner&&) noexcept;

  // Factors `a` (symmetric; both triangles are stored, the upper one is read).
  // Returns, with the previous state kept:
  //   InvalidArgument naming the field if the options are invalid;
  //   Numerical naming the scalar and block row of a non-finite entry or of a
  //     diagonal entry <= 0 (A is not positive definite);
  //   Numerical naming the shifts tried if Eigen reports that every pivot
  //     sequence broke down (A is probably indefinite);
  //   Numerical naming the column of a non-finite entry of L.
  [[nodiscard]] Status Update(const BlockSparseMatrix& a);

  // 0 before the first successful Update.
  int num_rows() const override { return num_rows_; }

  // y += M^{-1} x. Requires a successful Update (GS_CHECK).
  void RightMultiplyAndAccumulate(const double* x, double* y) const override;

  // Nonzeros of L and of tril(G), diagonal included; equal by construction
  // (see the picture above). 0 before the first successful Update.
  int64_t num_factor_nonzeros() const;
  int64_t num_pattern_nonzeros() const { return num_pattern_nonzeros_; }

  const IncompleteCholeskyOptions& options() const { return options_; }

 private:
  struct Factor;  // Eigen's factor object and the solve scratch (.cc)

  IncompleteCholeskyOptions options_;
  int num_rows_ = 0;
  int64_t num_pattern_nonzeros_ = 0;
  std::unique_ptr<Factor> factor_;  // null until the first successful Update
  std::unique_ptr<Factor> spare_;   // Update's output before it is swapped in
};

}  // namespace graphslam::core
