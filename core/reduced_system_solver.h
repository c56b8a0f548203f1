// ReducedSystemSolver: the linear solve of the reduced pose system
//
//   S dx = rhs      (S = reduced information + LM damping, rhs = -reduced gradient)
//
// across all Levenberg-Marquardt iterations of one run. It owns:
//
// 1. The choice between CHOLMOD and PCG (LinearSolverType::kAuto), made once
//    from CHOLMOD's own symbolic analysis of S's pattern (AMD ordering):
//      factor bytes   = 8 lnz                  (nonzeros of L)
//      cholmod cost   = fl + 4 lnz             (factor flops + two solves)
//      pcg cost       = K (2 nnz(S) + 4 n b)   per solve (K products with S)
//    CHOLMOD if factor bytes <= max_factor_bytes and cholmod cost <=
//    pcg cost, else PCG (ChooseFromAnalysis). Above max_analysis_unknowns
//    the analysis itself is skipped (it costs O(nnz) memory and an AMD pass)
//    and PCG is used. K is a crossover, not a CG count: it folds in CG
//    iterations per solve, the preconditioner, the flop rates of a
//    supernodal factorization against a sparse product, and the extra LM
//    iterations of inexact steps. It differs by problem class: pose graphs
//    (no eliminated features) need hundreds of CG iterations per solve on
//    loop closures, so K = kPoseGraphCrossover; on landmark problems
//    (features eliminated into S) the subgraph-preconditioned CG converges
//    in tens of iterations, so K = kLandmarkCrossover (figures:
//    docs/tuning.md).
//    `--solver pcg|cholmod` overrides.
//
// 2. For PCG, an inexact-Newton forcing sequence (Eisenstat & Walker,
//    "Choosing the forcing terms in an inexact Newton method", SIAM J. Sci.
//    Comput. 17(1), 1996, choice 2 with gamma = 0.9, alpha = 2):
//      eta_0 = eta_max
//      eta_k = gamma (|rhs_k| / |rhs_{k-1}|)^alpha      after an accepted step
//      safeguard: eta_k = max(eta_k, gamma eta_{k-1}^alpha) if gamma eta_{k-1}^alpha > 0.1
//      eta_k = clamp(eta_k, eta_min, eta_max)
//    and PCG stops at |S dx - rhs| <= eta_k |rhs|. rhs is the reduced gradient,
//    so the ratio is the Gauss-Newton progress: far from the optimum a rough
//    step (eta 0.1) is as good as an exact one, near it the tolerance tightens
//    quadratically and the iteration keeps Newton's local convergence. After a
//    rejected step the linearization is the same and eta is kept.
//    eta_max = 0.01, eta_min = the exact-solve tolerance. Ceres' 0.1 saves
//    CG iterations per step but costs LM iterations, each a pass over the
//    observations (figures: docs/tuning.md).
//
// 2b. Truncation that follows the LM objective (truncation > 0): PCG also
//    stops when the chi2 decrease the step still leaves on the table is
//    estimated (core/preconditioned_conjugate_gradient.h, the energy test)
//    below truncation * chi2, chi2 the objective at the linearization:
//      |dx_i - dx*|_S^2 <= truncation chi2.
//    |dx - dx*|_S^2 is the model decrease the truncated step gives up (S
//    the damped system, the LM model chi2 - |r + J d|^2 = 2 rhs^T d - d^T S d
//    + lambda d^T D d). The forcing term of item 2 measures the residual
//    relative to |rhs|, which near the optimum keeps asking for the same 1 %
//    although the whole step is worth a 1e-6 relative decrease of chi2, and
//    the system is hardest there (lambda ~1e-8): the late LM iterations take
//    most of the CG iterations on observed landmark problems (docs/tuning.md).
//    The energy test ends those solves as soon as what is left is below what
//    LM can see: the solver passes truncation = 0.1 * function tolerance, so
//    a truncated step decreases chi2 within 0.1 x the convergence test's
//    threshold of the exact step, and the optimum found moves by that much at
//    most. Far from the optimum the threshold is far below the step's gain
//    and item 2 decides.
//
// 3. Warm start: x0 = alpha x_prev, the previous solution scaled to minimize
//    the quadratic model q(x) = x^T S x / 2 - rhs^T x along it,
//      alpha = rhs^T x_prev / x_prev^T S x_prev   (x0 = 0 if alpha <= 0),
//    so x0 is never worse than zero in the S-norm; it helps most after a
//    rejected step (same linearization, more damping) and costs one product.
//
// 4. Exact model decrease. The LM driver computes the model decrease from
//    dx^T S dx = rhs^T dx, which CG from x0 = 0 satisfies exactly (its
//    residual is orthogonal to the Krylov space containing dx) but a warm
//    started or truncated CG need not. Every PCG result is therefore rescaled
//    by the same alpha (one more product), after which rhs^T dx = dx^T S dx.
//
// 5. Trajectory deflation (deflation_poses > 0, core/trajectory_deflation.h):
//    the preconditioner is wrapped in the deflation projector over aggregates
//    of deflation_poses consecutive poses, and the (warm) start gets the
//    coarse correction x0 += W E^{-1} W^T (rhs - S x0) first (one product).
//
// THREAD SAFETY: one object per solve; not thread-safe.
// ALLOCATION: O(n) vectors kept across calls; the analysis and the
// preconditioners allocate on their Update (see their headers).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>

#include "core/block_jacobi_preconditioner.h"
#include "core/block_sparse_matrix.h"
#include "core/cholmod_solver.h"
#include "core/graphslam_solver.h"
#include "core/incomplete_cholesky_preconditioner.h"
#include "core/pcg_solver_state.h"
#include "core/status.h"
#include "core/subgraph_preconditioner.h"
#include "core/trajectory_deflation.h"

namespace graphslam::core {

struct ReducedSystemSolverOptions {
  LinearSolverType type = LinearSolverType::kAuto;
  PreconditionerType preconditioner = PreconditionerType::kSubgraph;
  int pcg_max_iterations = 2000;
  // The tolerance of an exact solve, and eta_min of the forcing sequence.
  double pcg_relative_tolerance = 1e-10;
  bool forcing_sequence = true;
  double eta_max = 0.01;
  // Item 2b: a fraction of chi2; 0: off.
  double truncation = 0.0;
  bool warm_start = true;
  // PCG: trajectory deflation (core/trajectory_deflation.h) with this many
  // consecutive poses per aggregate; 0: off.
  int deflation_poses = 0;
  // kAuto: CHOLMOD only if its factor fits in this many bytes.
  int64_t max_factor_bytes = int64_t{4} << 30;
  // kAuto: above this many scalar unknowns, PCG without analysing.
  int64_t max_analysis_unknowns = 3'000'000;
  // kCholmod (chosen by the caller): when set, CHOLMOD's symbolic analysis
  // runs up front and this is called with its factor's bytes (8 lnz) before
  // any numeric factorization; an error is returned as is (a memory limit
  // the factor does not fit). The analysis is handed to the solver.
  std::function<Status(double factor_bytes)> cholmod_factor_check;
  // kAuto: S has features eliminated into it (a landmark problem, not a
  // pose graph); selects the crossover constant of item 1.
  bool eliminated_features = false;

  [[nodiscard]] Status Validate() const;
};

// What the kAuto analysis found (zeros when it did not run).
struct SolverChoice {
  LinearSolverType type = LinearSolverType::kCholmod;
  bool analyzed = false;
  double factor_nonzeros = 0;  // CHOLMOD's lnz
  double factor_flops = 0;     // CHOLMOD's fl
  double pcg_cost = 0;         // the estimate above, flops per solve
  // The analysis itself, for the CHOLMOD solver (ReducedSystemSolver::UseOrdering).
  std::shared_ptr<const CholmodOrdering> ordering;
};

// The analysis of item 1, on S's pattern (values are not read).
StatusOr<SolverChoice> ChooseLinearSolver(const BlockSparseMatrix& s,
                                          const ReducedSystemSolverOptions& options);

// The kAuto rule of item 1 on the analysis figures, apart so that it can be
// checked on the figures of known problems. Fills choice->type and
// choice->pcg_cost from choice->factor_nonzeros and factor_flops; `nonzeros`
// are S's scalar nonzeros (both triangles), n its rows, b its block size.
void ChooseFromAnalysis(double nonzeros, double n, double b,
                        const ReducedSystemSolverOptions& options, SolverChoice* choice);

// Products with S per solve at which PCG and CHOLMOD cost the same (item 1;
// docs/tuning.md).
inline constexpr double kPoseGraphCrossover = 1000.0;
inline constexpr double kLandmarkCrossover = 40.0;

class ReducedSystemSolver {
 public:
  // Requires options.Validate().ok(). type must not be kAuto (call
  // ChooseLinearSolver first).
  ReducedSystemSolver(LinearSolverType type, const ReducedSystemSolverOptions& options);

  // Solves s dx = rhs into *x. *iterations: PCG iterations (1 for CHOLMOD).
  // chi2: the objective at the linearization, for item 2b (0: no truncation).
  [[nodiscard]] Status Solve(const BlockSparseMatrix& s, const Eigen::VectorXd& rhs,
                             Eigen::VectorXd* x, int* iterations, double chi2 = 0.0);

  // The ordering ChooseLinearSolver computed for the pattern of the
  // matrices to come (CHOLMOD does not order them again).
  void UseOrdering(std::shared_ptr<const CholmodOrdering> ordering);

  // The LM driver tells whether the last solve's step was accepted.
  void StepResult(bool accepted);

  // Checkpointing (core/pcg_solver_state.h). SaveState fills *state with
  // everything the next PCG solve depends on (present = false for CHOLMOD).
  // RestoreState takes over a saved state before the first Solve, for
  // matrices with the pattern of `pattern`; a state that is not present is
  // ignored (a fresh start), and so is what does not apply to this solver
  // (a PCG state given to CHOLMOD, a forest to another preconditioner).
  // InvalidArgument naming the field if it does not fit the pattern or is
  // not finite; the solver is then unchanged.
  void SaveState(PcgSolverState* state) const;
  [[nodiscard]] Status RestoreState(const PcgSolverState& state,
                                    const BlockSparseMatrix& pattern);

  LinearSolverType type() const { return type_; }
  double eta() const { return eta_; }

 private:
  const LinearOperator* UpdatePreconditioner(const BlockSparseMatrix& s, Status* status);

  LinearSolverType type_;
  ReducedSystemSolverOptions options_;
  CholmodSolver cholmod_;
  BlockJacobiPreconditioner block_jacobi_;
  IncompleteCholeskyPreconditioner incomplete_cholesky_;
  SubgraphPreconditioner subgraph_;
  std::unique_ptr<TrajectoryDeflation> deflation_;  // when deflation_poses > 0
  Eigen::VectorXd previous_x_;
  Eigen::VectorXd product_;       // scratch: S x
  double previous_rhs_norm_ = -1;  // |rhs| of the last accepted linearization
  double last_rhs_norm_ = -1;
  double eta_;
  bool have_previous_ = false;
};

}  // namespace graphslam::core
