#include "distributed/mpi_ranks.h"

#include <algorithm>
#include <chrono>
#include <string>

#include "distributed/chunk_assignment.h"

namespace graphslam::distributed {
namespace {

// Counts one reduction of `bytes` payload bytes in *stats and adds the
// seconds to its end (the waits for slower ranks included).
class ReductionTimer {
 public:
  ReductionTimer(ExchangeStats* stats, int64_t bytes)
      : stats_(stats), start_(std::chrono::steady_clock::now()) {
    stats_->reductions += 1;
    stats_->reduction_bytes += bytes;
  }
  ~ReductionTimer() {
    stats_->reduction_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  ExchangeStats* stats_;
  std::chrono::steady_clock::time_point start_;
};

}  // namespace

MpiRanks::MpiRanks(MPI_Comm comm) : comm_(comm) {
  MPI_Comm_rank(comm, &rank_);
  MPI_Comm_size(comm, &size_);
}

Status MpiRanks::Agree(Status status) {
  // The lowest failing rank's message is not sent: the failing rank has its
  // own; the others name it.
  int failed = status.ok() ? size_ : rank_;
  int first_failed = size_;
  const ReductionTimer timer(&stats_, sizeof(int));
  MPI_Allreduce(&failed, &first_failed, 1, MPI_INT, MPI_MIN, comm_);
  if (!status.ok()) return status;
  if (first_failed == size_) return Status::Ok();
  return Status::Numerical("MPI rank " + std::to_string(first_failed) +
                           " failed (its own message is in its log)");
}

void MpiRanks::SumSystem(core::ReducedSystem* system) {
  const ReductionTimer timer(
      &stats_, 8 * (system->gradient.size() + system->hessian_diagonal.size() + 1));
  MPI_Allreduce(MPI_IN_PLACE, system->gradient.data(), static_cast<int>(system->gradient.size()),
                MPI_DOUBLE, MPI_SUM, comm_);
  MPI_Allreduce(MPI_IN_PLACE, system->hessian_diagonal.data(),
                static_cast<int>(system->hessian_diagonal.size()), MPI_DOUBLE, MPI_SUM, comm_);
  MPI_Allreduce(MPI_IN_PLACE, &system->chi2, 1, MPI_DOUBLE, MPI_SUM, comm_);
}

void MpiRanks::SumRecovery(core::RecoveryResult* recovery) {
  double sums[5] = {recovery->candidate_chi2, recovery->gradient_dot_step,
                    recovery->damped_step_norm, recovery->step_squared_norm,
                    recovery->state_squared_norm};
  const ReductionTimer timer(&stats_, sizeof(sums));
  MPI_Allreduce(MPI_IN_PLACE, sums, 5, MPI_DOUBLE, MPI_SUM, comm_);
  recovery->candidate_chi2 = sums[0];
  recovery->gradient_dot_step = sums[1];
  recovery->damped_step_norm = sums[2];
  recovery->step_squared_norm = sums[3];
  recovery->state_squared_norm = sums[4];
}

void MpiRanks::SumScreening(core::ScreeningResult* screening) {
  const int k = static_cast<int>(shared_);
  const ReductionTimer timer(&stats_, 2 * int64_t{k} + 24);
  MPI_Allreduce(MPI_IN_PLACE, screening->excluded.data(), k, MPI_UINT8_T, MPI_MIN, comm_);
  MPI_Allreduce(MPI_IN_PLACE, screening->kept.data(), k, MPI_UINT8_T, MPI_MAX, comm_);
  const auto own_begin = screening->excluded.begin() + k;
  int64_t counts[3] = {screening->excluded_not_positive_definite, screening->observations,
                       std::count(own_begin, screening->excluded.end(), 1)};
  MPI_Allreduce(MPI_IN_PLACE, counts, 3, MPI_INT64_T, MPI_SUM, comm_);
  screening->excluded_not_positive_definite = counts[0];
  screening->observations = counts[1];
  // Kept features are shared ones (more observations than any eliminated
  // feature has), so this count is the same on every rank.
  screening->kept_count = std::count(screening->kept.begin(), screening->kept.end(), 1);
  const int64_t excluded =
      std::count(screening->excluded.begin(), own_begin, 1) + counts[2] + outside_;
  screening->unobserved = excluded - counts[0];
}

void MpiRanks::SumChi2(double* chi2) {
  const ReductionTimer timer(&stats_, sizeof(double));
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
