#include "distributed/mpi_ranks.h"

#include <algorithm>
#include <string>

#include "distributed/chunk_assignment.h"

namespace graphslam::distributed {

MpiRanks::MpiRanks(MPI_Comm comm) : comm_(comm) {
  MPI_Comm_rank(comm, &rank_);
  MPI_Comm_size(comm, &size_);
}

Status MpiRanks::Agree(Status status) {
  // The lowest failing rank's message is not sent: the failing rank has its
  // own; the others name it.
  int failed = status.ok() ? size_ : rank_;
  int first_failed = size_;
  MPI_Allreduce(&failed, &first_failed, 1, MPI_INT, MPI_MIN, comm_);
  if (!status.ok()) return status;
  if (first_failed == size_) return Status::Ok();
  return Status::Numerical("MPI rank " + std::to_string(first_failed) +
                           " failed (its own message is in its log)");
}

void MpiRanks::SumSystem(core::ReducedSystem* system) {
  MPI_Allreduce(MPI_IN_PLACE, system->gradient.data(), static_cast<int>(system->gradient.size()),
                MPI_DOUBLE, MPI_SUM, comm_);
  MPI_Allreduce(MPI_IN_PLACE, system->hessian_diagonal.data(),
                static_cast<int>(system->hessian_diagonal.size()), MPI_DOUBLE, MPI_SUM, comm_);
  SumChi2(&system->chi2);
}

void MpiRanks::SumRecovery(core::RecoveryResult* recovery) {
  double sums[5] = {recovery->candidate_chi2, recovery->gradient_dot_step,
                    recovery->damped_step_norm, recovery->step_squared_norm,
                    recovery->state_squared_norm};
  MPI_Allreduce(MPI_IN_PLACE, sums, 5, MPI_DOUBLE, MPI_SUM, comm_);
  recovery->candidate_chi2 = sums[0];
  recovery->gradient_dot_step = sums[1];
  recovery->damped_step_norm = sums[2];
  recovery->step_squared_norm = sums[3];
  recovery->state_squared_norm = sums[4];
}

void MpiRanks::SumScreening(core::ScreeningResult* screening) {
  const int n = static_cast<int>(screening->excluded.size());
  MPI_Allreduce(MPI_IN_PLACE, screening->excluded.data(), n, MPI_UINT8_T, MPI_MIN, comm_);
  MPI_Allreduce(MPI_IN_PLACE, screening->kept.data(), n, MPI_UINT8_T, MPI_MAX, comm_);
  int64_t counts[2] = {screening->excluded_not_positive_definite, screening->observations};
  MPI_Allreduce(MPI_IN_PLACE, counts, 2, MPI_INT64_T, MPI_SUM, comm_);
  screening->excluded_not_positive_definite = counts[0];
  screening->observations = counts[1];
  screening->kept_count = std::count(screening->kept.begin(), screening->kept.end(), 1);
  screening->unobserved =
      std::count(screening->excluded.begin(), screening->excluded.end(), 1) - counts[0];
}

void MpiRanks::SumChi2(double* chi2) {
  MPI_Allreduce(MPI_IN_PLACE, chi2, 1, MPI_DOUBLE, MPI_SUM, comm_);
}

StatusOr<std::unique_ptr<PetscReducedSolver>> MpiRanks::MakeLinearSolver(
    const core::BlockSparseMatrix& pattern, const core::ReducedSystemSolverOptions& options,
    core::SolverSummary* summary) {
  StatusOr<std::unique_ptr<PetscReducedSolver>> solver = PetscReducedSolver::Create(
      comm_, pattern, SplitRows(pattern.num_block_rows(), size_), options, &stats_);
  GS_RETURN_IF_ERROR(Agree(solver.status()));
  summary->linear_solver_used = core::LinearSolverType::kPcg;  // a Krylov solve (PETSc KSP)
  // S's nonzero blocks over all ranks (the pattern passed in is this rank's).
  int64_t blocks = stats_.row_blocks;
  MPI_Allreduce(MPI_IN_PLACE, &blocks, 1, MPI_INT64_T, MPI_SUM, comm_);
  summary->reduced_nonzero_blocks = blocks;
  return solver;
}

}  // namespace graphslam::distributed
