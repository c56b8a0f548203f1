// MpiRanks: the Ranks policy of SolveChunkedWith
// (core/internal/chunked_solve_impl.h) over the processes of an MPI
// communicator. Each rank passes over its own chunks only
// (distributed/chunk_assignment.h); what the Levenberg-Marquardt control
// reads is summed over the ranks with MPI_Allreduce before it reads it:
//
//   system    g_x, diag(H_xx), chi2         (n + n + 1 doubles per reduction)
//   recovery  chi2 at the candidate, sum g_m^T dm, dm^T D_m dm, |dm|^2, |m|^2
//   screening per shared feature (distributed/feature_ownership.h, the
//             first `shared` entries of every rank's local arrays):
//             excluded = AND over ranks (a feature is in one chunk, every
//             other rank sees it unobserved), kept = OR; the rank's other
//             features are its own; counts
//   status    a pass that fails on one rank fails on all (MPI_MAX of a flag)
//
// so every rank holds the same numbers and takes the same decisions. Rank 0
// linearizes the pose-only factors (odometry, motion, GPS) into its part of
// S. The poses and every sum are replicated (O(n) per rank); the features are
// each rank's own, in its local numbering. The reduced system is solved by PetscReducedSolver
// (distributed/petsc_reduced_solver.h).
//
// THREAD SAFETY: collective; every rank calls the same methods in the same
// order. ALLOCATION: none in SumScreening, O(n) in SumSystem.
#pragma once

#include <mpi.h>

#include <memory>
#include <vector>

#include "core/chunk_passes.h"
#include "core/graphslam_solver.h"
#include "core/reduced_system_solver.h"
#include "core/status.h"
#include "distributed/petsc_reduced_solver.h"

namespace graphslam::distributed {

class MpiRanks {
 public:
  using LinearSolver = PetscReducedSolver;

  explicit MpiRanks(MPI_Comm comm);

  // The local feature arrays' first `shared` entries are the shared
  // features; `outside` features are in no chunk (no rank holds them; they
  // count as unobserved).
  void SetFeatureLayout(int64_t shared, int64_t outside) {
    shared_ = shared;
    outside_ = outside;
  }
  bool AddsPoseFactors() const { return rank_ == 0; }
  Status Agree(Status status);
  void SumSystem(core::ReducedSystem* system);
  void SumRecovery(core::RecoveryResult* recovery);
  void SumScreening(core::ScreeningResult* screening);
  void SumChi2(double* chi2);
  // Collective: splits the block rows (SplitRows) and builds the solver.
  StatusOr<std::unique_ptr<LinearSolver>> MakeLinearSolver(
      const core::BlockSparseMatrix& pattern, const core::ReducedSystemSolverOptions& options,
      core::SolverSummary* summary);

  int rank() const { return rank_; }
  int size() const { return size_; }
  // What the solver MakeLinearSolver made did (kept after it is gone).
  const ExchangeStats& stats() const { return stats_; }

 private:
  MPI_Comm comm_;
  int rank_ = 0;
  int size_ = 1;
  int64_t shared_ = 0;
  int64_t outside_ = 0;
  ExchangeStats stats_;
};

}  // namespace graphslam::distributed
