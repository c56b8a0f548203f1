// The one solve path of the application layer, for every front end and both
// dimensions:
//
//   RunSolve(request)
//     1. check     every output writable where it goes, before any work
//     2. launch    under mpirun, a chunk store is solved over the ranks
//     3. detect    chunk store, --workdir ingest, or a file's format
//                  (storage/format_detection.h) and dimension
//     4. read      the problem (storage)
//     5. initialize  Table 1, or --initialization's choice (2-D)
//     6. solve     Levenberg-Marquardt over the chunks (core), with
//                  checkpoints, --resume, association, streaming (2-D)
//     7. write     -o, --tum, --features-csv, --report (each atomically, after
//                  a successful solve only), then the terminal summary
//
// Steps 4-7 are one template over the problem space
// (tools/pipeline/solve_path.h: RunSolvePath), with the 2-D hooks in
// tools/pipeline/solve_2d.cc and the 3-D ones in tools/pipeline/solve_3d.cc;
// both take the same request, and the report and summary share their keys
// and lines.
//
// THREAD SAFETY: one call at a time per process (the TBB thread limit and the
// log verbosity are process-wide). ALLOCATION: the problem in memory, or its
// poses when a chunk store streams its observations from disk.
#pragma once

#include <string>

#include "core/graphslam_solver.h"
#include "core/problem_3d.h"
#include "core/status.h"
#include "tools/pipeline/solve_request.h"

namespace graphslam::tools {

// Runs `request` and returns the process exit code (tools/exit_codes.h);
// a failure is printed as "graphslam solve: STATUS" on stderr first.
int RunSolve(const SolveRequest& request);

// The programmatic 3-D hook (e.g. building a map from scans): reads `path`
// (format detected from the content), initializes and optimizes it; returns
// the optimized pose of every pose id. *summary (optional) receives the solver
// summary. A solve that stops without converging is not an error here; check
// summary->converged.
StatusOr<core::OptimizedPoses3d> SolvePoses3dFile(const std::string& path,
                                                  const core::SolverOptions& options,
                                                  core::SolverSummary* summary = nullptr);

}  // namespace graphslam::tools
