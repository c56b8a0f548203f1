// The part of `graphslam solve STORE/` and `graphslam ingest` that runs
// under mpirun (docs/distributed.md): started when an MPI launcher started
// this process (for solve: and the input is a chunk store). Built with MPI and PETSc
// (GRAPHSLAM_WITH_MPI, tools/distributed_solve_command.cc); without them
// (tools/distributed_solve_none.cc) Start says so and a single launched
// process solves as usual.
//
// THREAD SAFETY: main thread only. ALLOCATION: the distributed solve's.
#pragma once

#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "storage/chunk_store.h"

namespace graphslam::tools {

// The process count an MPI launcher put into the environment
// (OMPI_COMM_WORLD_SIZE, PMI_SIZE); 0 when no launcher started us.
int LaunchedProcesses();

class DistributedSolveRun {
 public:
  // MPI and PETSc for this process, `petsc_options` added to PETSc's options.
  // NotSupported when built without them.
  static StatusOr<std::unique_ptr<DistributedSolveRun>> Start(const std::string& petsc_options);
  virtual ~DistributedSolveRun() = default;

  virtual int rank() const = 0;
  virtual int size() const = 0;
  // Ends every process of the run with `exit_code` (MPI_Abort).
  [[noreturn]] virtual void Abort(int exit_code) = 0;
  // Collective: distributed/distributed_solve.h on `store`; adds the
  // "distributed" object (ranks, chunks and observations per rank, KSP / PC,
  // bytes sent per solve by this rank) to *report.
  virtual Status Solve(const core::SolverOptions& options, const storage::DiskChunkSource& store,
                       core::Problem2d* problem, core::SolverSummary* summary,
                       nlohmann::json* report) = 0;
  // Collective: returns once every process called it (waiting without
  // spinning on a core).
  virtual void Barrier() = 0;
  // Collective, for the ingest on ranks (partition::IngestRanks::gather):
  // every rank's shard entries to rank 0, which gets all of them in chunk
  // order (rank order) and the shards.
  virtual Status GatherChunkEntries(std::vector<storage::ChunkStoreEntry>* entries,
                                    std::vector<storage::ChunkStoreShard>* shards) = 0;
};

}  // namespace graphslam::tools
