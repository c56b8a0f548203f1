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
// Not here: checkpoints and --resume (options.checkpoint_callback and
// resume_from must be empty), the candidate store, 3-D stores.
//
// THREAD SAFETY: collective. ALLOCATION: as the one-process solve, plus the
// exchange (PetscReducedSolver) and O(features) for steps 1 and 4.
#pragma once

#include <mpi.h>

#include <cstdint>
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
};

// `chunk_observations[k]`: chunk k's observation count (the manifest's).
// Collective; the same Status on every rank.
Status SolveGraphSlamDistributed(MPI_Comm comm, const core::SolverOptions& options,
                                 const core::ChunkSource& chunks,
                                 const std::vector<int64_t>& chunk_observations,
                                 core::Problem2d* problem, core::SolverSummary* summary,
                                 DistributedSolveInfo* info);

}  // namespace graphslam::distributed
