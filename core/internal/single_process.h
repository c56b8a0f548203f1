// SingleProcess: the Ranks policy of SolveChunkedWith
// (core/internal/chunked_solve_impl.h) for a solve in one process. It owns
// no other process, so every sum is the identity and every status is its
// own; its linear solver is ReducedSystemSolver (core/reduced_system_solver.h)
// chosen by ChooseLinearSolver, damped in place:
//
//   S <- S + lambda diag(D),   then ReducedSystemSolver::Solve(S, rhs).
//
// THREAD SAFETY: one object per solve. ALLOCATION: the solver's.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <utility>

#include "core/chunk_passes.h"
#include "core/graphslam_solver.h"
#include "core/logging.h"
#include "core/reduced_system_solver.h"
#include "core/status.h"

namespace graphslam::core::internal {

class SingleProcess {
 public:
  class LinearSolver {
   public:
    LinearSolver(LinearSolverType type, const ReducedSystemSolverOptions& options)
        : solver_(type, options) {}
    Status Solve(double lambda, const Eigen::VectorXd& damping, ReducedSystem* system,
                 Eigen::VectorXd* x, int* iterations, double chi2) {
      system->matrix.AddToDiagonal(lambda * damping);
      return solver_.Solve(system->matrix, system->rhs, x, iterations, chi2);
    }
    void UseOrdering(std::shared_ptr<const CholmodOrdering> ordering) {
      solver_.UseOrdering(std::move(ordering));
    }
    void StepResult(bool accepted) { solver_.StepResult(accepted); }
    void SaveState(PcgSolverState* state) const { solver_.SaveState(state); }
    Status RestoreState(const PcgSolverState& state, const BlockSparseMatrix& pattern) {
      return solver_.RestoreState(state, pattern);
    }

   private:
    ReducedSystemSolver solver_;
  };

  bool AddsPoseFactors() const { return true; }
  Status Agree(Status status) { return status; }
  void SumSystem(ReducedSystem* /*system*/) {}
  void SumRecovery(RecoveryResult* /*recovery*/) {}
  void SumScreening(ScreeningResult* /*screening*/) {}
  void SumChi2(double* /*chi2*/) {}

  // kAuto picks CHOLMOD or PCG from CHOLMOD's symbolic analysis of the
  // pattern (core/reduced_system_solver.h, item 1).
  StatusOr<std::unique_ptr<LinearSolver>> MakeLinearSolver(
      const BlockSparseMatrix& pattern, const ReducedSystemSolverOptions& options,
      SolverSummary* summary) {
    StatusOr<SolverChoice> choice = ChooseLinearSolver(pattern, options);
    GS_RETURN_IF_ERROR(choice.status());
    const LinearSolverType type = choice->type;
    if (choice->analyzed) {
      GS_VLOG(1, "solver choice: CHOLMOD factor %.3g nonzeros, %.3g flops; PCG estimate %.3g "
              "flops (%s crossover) -> %s", choice->factor_nonzeros, choice->factor_flops,
              choice->pcg_cost, options.eliminated_features ? "landmark" : "pose-graph",
              LinearSolverName(type));
    }
    summary->linear_solver_used = type;
    auto solver = std::make_unique<LinearSolver>(type, options);
    if (type == LinearSolverType::kCholmod) solver->UseOrdering(std::move(choice->ordering));
    return solver;
  }
};

}  // namespace graphslam::core::internal
