// Trajectory deflation: a coarse space for PCG on the reduced pose system that
// removes the smooth, long-wavelength error modes of the trajectory, which a
// spanning-tree (or any local) preconditioner leaves to CG.
//
// Why. On landmark problems with many observations per pose (sim1e5obs,
// sim1e6obs in docs/benchmarks.md) S is the odometry chain (blocks |i-k| = 1,
// scale-free weight ~0.46) plus ~20 weak blocks per row from landmarks seen
// again on later passes (weight ~0.002 each). The subgraph preconditioner
// solves the chain exactly; what CG must still find is how the stiff chain
// bends and shifts as a whole under the many weak couplings: a few hundred
// iterations near the optimum, where LM's damping vanishes.
//
// Coarse space. Block rows are poses in trajectory order. They are split into
// aggregates of m consecutive poses (the last takes the remainder, so every
// aggregate has >= min(m, n) poses). For aggregate a with poses lo..hi and
// centre c = (lo + hi) / 2, W has b + L columns:
//
//   W_{i, a} = [ I_b ,  t_i P ]  for i in a,   t_i = (i - c) / m,   0 elsewhere
//
// where P (b x L) picks the L components that also get a linear-in-time
// mode: a constant mode per increment component (the segment translated, its
// heading turned) and linear ones (with the increments in the body frame, a
// segment along a straight street turned about its centre moves its poses
// laterally in proportion to t_i). DefaultLinearComponents is {y} for SE(2)
// (b = 3; 4 columns per aggregate: E's factor and solve cost ~(4/6)^2 of
// six): the linear mode across the street did most of the work of all three
// (docs/tuning.md); every component for other block sizes.
//
// Deflated CG (Y. Saad, M. Yeung, J. Erhel, F. Guyomarc'h, "A deflated version
// of the conjugate gradient algorithm", SIAM J. Sci. Comput. 21(5), 2000),
// with E = W^T S W (Galerkin coarse matrix, positive definite when S is and
// W has full column rank) and Q = W E^{-1} W^T:
//
//   x_0 = x_in + Q (b - S x_in)                     (CoarseCorrect: W^T r_0 = 0)
//   z   = (I - W E^{-1} (S W)^T) M^{-1} r           (RightMultiplyAndAccumulate)
//
// and otherwise plain PCG (SolvePcg). With W^T r_j = 0 this operator gives
// exactly Saad's search directions p = z - W E^{-1} (SW)^T z (and r^T z is
// unchanged by the projection), so CG keeps every residual orthogonal to W
// and never has to resolve the coarse modes; as a preconditioner it is the
// "A-DEF2" form of J. M. Tang, R. Nabben, C. Vuik, Y. A. Erlangga,
// "Comparison of two-level preconditioners derived from deflation, domain
// decomposition and multigrid methods", J. Sci. Comput. 39, 2009. It costs
// per CG iteration one product with S W (n x (b + L) na) and a solve with
// E's CHOLMOD factor ((b + L) na unknowns); per Update one pass over S's
// blocks and a factorization of E. (SolvePcg's periodic residual recompute
// r = b - S x keeps W^T r = 0 up to rounding, since x_j - x_0 lies in the
// range of the projected operator.)
//
// When it pays: on densely observed landmark problems, where the error left
// by PCG is smooth along the trajectory; on pose graphs with many loop
// closures it is not, and deflation costs more than it saves (figures:
// docs/tuning.md). Hence off by default (SolverOptions::pcg_deflation_poses =
// 0, `--pcg-deflation`).
//
// THREAD SAFETY: RightMultiplyAndAccumulate is const and serialized by a
// mutex (scratch vectors, CHOLMOD's workspace). Update must not run
// concurrently with anything else.
// ALLOCATION: Update allocates O(nonzero blocks of S W + of E) and E's
// factor; RightMultiplyAndAccumulate allocates E's solution vector.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <mutex>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/cholmod_solver.h"
#include "core/linear_operator.h"
#include "core/status.h"

namespace graphslam::core {

class TrajectoryDeflation : public LinearOperator {
 public:
  // `inner` is the preconditioner M^{-1} (borrowed; must outlive this object
  // and be updated before each Update). Requires poses_per_aggregate >= 2.
  // linear_components: the components with a linear mode (P above).
  TrajectoryDeflation(const LinearOperator* inner, int poses_per_aggregate,
                      std::vector<int> linear_components);

  // {1} (y) for block size 3, all components otherwise (see above).
  static std::vector<int> DefaultLinearComponents(int block_size);

  // Builds W's aggregates, S W and E = W^T S W, and factors E. Numerical if E
  // is not positive definite (S is not), InvalidArgument if `inner` has
  // another size than S or a linear component is not one of S's block
  // components. With fewer than 2 block rows the deflation is off (the
  // operator is `inner`, CoarseCorrect does nothing).
  [[nodiscard]] Status Update(const BlockSparseMatrix& s);

  int num_rows() const override { return num_rows_; }

  // y += (I - W E^{-1} (S W)^T) M^{-1} x. Requires a successful Update.
  void RightMultiplyAndAccumulate(const double* x, double* y) const override;

  // x += W E^{-1} W^T (b - S x): the start of a deflated CG (one product
  // with S). Requires a successful Update with this S.
  [[nodiscard]] Status CoarseCorrect(const BlockSparseMatrix& s, const Eigen::VectorXd& b,
                                     Eigen::VectorXd* x) const;

  int num_aggregates() const { return num_aggregates_; }
  int coarse_unknowns() const { return num_aggregates_ * width_; }

 private:
  // W^T v (v: n entries) into out (coarse_unknowns() entries).
  void RestrictTo(const double* v, Eigen::VectorXd* out) const;
  // y += sign * W c.
  void Prolong(const Eigen::VectorXd& c, double sign, double* y) const;

  const LinearOperator* inner_;
  int poses_per_aggregate_;
  std::vector<int> linear_;  // components with a linear mode
  int width_ = 0;            // columns of W per aggregate: b + linear_.size()
  int num_rows_ = 0;
  int block_size_ = 0;
  int num_blocks_ = 0;
  int num_aggregates_ = 0;  // 0: deflation off
  std::vector<int> aggregate_;  // per block row
  std::vector<double> t_;       // per block row: (i - centre) / m
  // S W in block CSR: per block row i, blocks (i, aggregate) of b x 2b,
  // row-major.
  std::vector<int64_t> sw_row_start_;
  std::vector<int> sw_cols_;
  std::vector<double> sw_values_;
  CholmodSolver coarse_;  // E's factor
  mutable std::mutex mutex_;
  mutable std::vector<double> inner_result_;  // GUARDED_BY(mutex_), n entries
  mutable Eigen::VectorXd coarse_rhs_;        // GUARDED_BY(mutex_)
  mutable Eigen::VectorXd coarse_x_;          // GUARDED_BY(mutex_)
};

}  // namespace graphslam::core
