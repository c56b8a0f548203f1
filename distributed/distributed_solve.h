// SolveGraphSlamDistributed: `mpirun -np N graphslam solve STORE/`, the
// GraphSLAM solve of a planar chunk store over the N ranks of an MPI
// communicator (docs/distributed.md):
//
//   1. the start of rank 0 (poses; the caller may initialize on rank 0
//      only) is broadcast, so every rank starts from the same bits;
//   2. each rank owns the chunks AssignChunks gives it (contiguous, balanced
//      observation counts; distributed/chunk_assignment.h) and holds only
//      the features in them, numbered locally
//      (distributed/feature_ownership.h): their start values come from rank
//      0, and every per-feature array of the solve is of the rank's size;
//   3. SolveChunkedWith (core/internal/chunked_solve_impl.h), the one-process
//      solve's code, runs with the MpiRanks policy (distributed/mpi_ranks.h):
//      screening, reduce and recover over the rank's own chunks (TBB inside
//      the rank), sums over ranks, the reduced system in PETSc
//      (distributed/petsc_reduced_solver.h), the same Levenberg-Marquardt
//      control;
//   4. each feature's final estimate and excluded flag go from the rank
//      owning its chunk to rank 0, which ends with the whole solution and
//      the store-wide summary->excluded; the other ranks end with no
//      per-feature arrays (problem->features, feature_ids,
//      feature_initialized and summary->excluded empty). The summary's
//      feature counts are the store's on every rank.
//
// Checkpoints and --resume (distributed/checkpoint_exchange.h): after every
// iteration every rank's features and flags are gathered to rank 0, whose
// options.checkpoint_callback (called on rank 0 only) gets the whole state,
// as a one-process solve would; its status is every rank's, and then
// `checkpoint_durable(iteration)` runs on every rank (a test's stop point).
// options.resume_from is read on rank 0 only (the other ranks pass null):
// rank 0 sends each rank its part. Not here: the candidate store, 3-D stores.
//
// THREAD SAFETY: collective. ALLOCATION: as the one-process solve over the
// rank's own chunks and features, plus the exchange (PetscReducedSolver);
// rank 0 also holds the store-sized arrays (start, checkpoint, result).
#pragma once

#include <mpi.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/chunk_source.h"
#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "distributed/petsc_reduced_solver.h"

namespace graphslam::distributed {

// What the distributed solve did, per rank where it says so.
struct DistributedSolveInfo {
  int ranks = 1;
  std::vector<int64_t> chunks_per_rank;        // all ranks
  std::vector<int64_t> observations_per_rank;  // all ranks
  ExchangeStats exchange;                      // this rank's
  // Every rank's figures, on rank 0 only (docs/distributed.md, "Measured"):
  // its ExchangeStats, the wall seconds of its solve (SolveChunkedWith) and
  // of its checkpoint gathers, the bytes those gathers sent, and its peak
  // resident set size (getrusage) at the end of the solve.
  struct RankCosts {
    ExchangeStats exchange;
    double solve_seconds = 0;
    double checkpoint_seconds = 0;
    int64_t checkpoint_bytes_sent = 0;
    int64_t peak_rss_bytes = 0;
    double cpu_seconds = 0;  // the process's, at the end of the solve
  };
  std::vector<RankCosts> per_rank;
};

// `chunk_observations[k]`: chunk k's observation count (the manifest's).
// Collective; the same Status on every rank.
Status SolveGraphSlamDistributed(MPI_Comm comm, const core::SolverOptions& options,
                                 const core::ChunkSource& chunks,
                                 const std::vector<int64_t>& chunk_observations,
                                 core::Problem2d* problem, core::SolverSummary* summary,
                                 DistributedSolveInfo* info,
                                 const std::function<void(int)>& checkpoint_durable = {});

}  // namespace graphslam::distributed
