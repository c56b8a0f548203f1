// Reads a 2-D g2o file, solves it as `graphslam solve --initialization
// progressive` does (Table 1 guess, progressive initialization,
// Levenberg-Marquardt) and writes the result.
//   usage: graphslam_example IN.g2o OUT.g2o
#include <cstdio>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/initialization/progressive_initialization.h"
#include "storage/g2o_reader.h"
#include "storage/g2o_writer.h"

int main(int argc, char** argv) {
  using namespace graphslam;
  if (argc != 3) return std::fprintf(stderr, "usage: %s IN.g2o OUT.g2o\n", argv[0]), 1;
  StatusOr<core::Problem2d> problem = storage::ReadG2o(argv[1]);
  if (!problem.ok()) return std::fprintf(stderr, "%s\n", problem.status().ToString().c_str()), 2;
  core::SolverOptions options;  // the solver defaults of `graphslam solve`:
  options.initial_trust_region_radius = 0;  // by the linear solver (1e8 CHOLMOD, 1e4 PCG)
  partition::ProgressiveSummary progressive;
  core::SolverSummary summary;
  Status status = core::InitializeProblem(&*problem);
  if (status.ok())
    status = partition::InitializeProgressively({}, options, &*problem, &progressive);
  const partition::InMemoryChunkSource chunks(*problem, partition::ChunkingOptions());
  if (status.ok()) status = core::SolveGraphSlam(options, chunks, &*problem, &summary);
  if (status.ok()) status = storage::WriteG2o(*problem, argv[2]);
  if (!status.ok()) return std::fprintf(stderr, "%s\n", status.ToString().c_str()), 2;
  std::printf("initial chi2 %.17g\nfinal chi2 %.17g\niterations %d\n", summary.initial_chi2,
              summary.final_chi2, summary.iterations);
  return summary.converged ? 0 : 4;
}
