// SolveGraphSlamDistributed: `mpirun -np N graphslam solve STORE/`, the
// GraphSLAM solve of a planar chunk store over the N ranks of an MPI
// communicator (docs/distributed.md):
//
//   1. the start (poses, features) of rank 0 is broadcast, so every rank
//      starts from the same bits (the caller may initialize on rank 0 only);
//   2. each rank owns the chunks AssignChunks gives it (contiguous, balanced
//      observation counts; distributed/chunk_assignment.h);
//   3. SolveChunkedWith (core/internal/chunked_solve_impl.h), the one-process
//      solve's code, runs with the MpiRanks policy (distributed/mpi_ranks.h):
//      screening, reduce and recover over the rank's own chunks (TBB inside
//      the rank), sums over ranks, the reduced system in PETSc
//      (distributed/petsc_reduced_solver.h), the same Levenberg-Marquardt
//      control;
//   4. each feature's final estimate comes from the rank owning its chunk
//      (MPI_Allreduce of values that are 0 on every other rank: exact), so
//      every rank ends with the whole solution.
//
// Checkpoints and --resume (distributed/checkpoint_exchange.h): after every
// iteration the features are gathered to rank 0, whose
// options.checkpoint_callback (called on rank 0 only) gets the whole state,
// as a one-process solve would; its status is every rank's, and then
// `checkpoint_durable(iteration)` runs on every rank (a test's stop point).
// options.resume_from is read on rank 0 only (the other ranks pass null):
// rank 0 broadcasts it. Not here: the candidate store, 3-D stores.
//
// THREAD SAFETY: collective. ALLOCATION: as the one-process solve, plus the
// exchange (PetscReducedSolver) and O(features) for steps 1 and 4.
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
