// The 3-D branch of `graphslam solve`: read a 3-D g2o / iSAM input, chain the
// initial guess (core/initialization_3d.h), run SolveGraphSlam3d and write the
// same outputs and JSON report keys as the planar solve (-o OUT.g2o in the 3-D
// g2o records, --tum, --report), with --robust-kernel on the observations and
// --checkpoint / --resume (docs/formats/solver_checkpoint.md, 3-D poses).
// --features-csv and progressive initialization apply to 2-D only.
//
// SolvePoses3dFile is the programmatic hook for other tools (e.g. building a
// map from scans): the optimized pose of every pose id.
//
// THREAD SAFETY: one call per problem. ALLOCATION: the whole problem in memory.
#pragma once

#include <string>

#include "core/graphslam_solver.h"
#include "core/problem_3d.h"
#include "core/status.h"
#include "storage/format_detection.h"
#include "tools/solve_command.h"

namespace graphslam::tools {

// Reads `path` (a 3-D g2o or iSAM file) in `format`.
StatusOr<core::Problem3d> ReadProblem3d(const std::string& path, storage::InputFormat format);

// Reads (format detected from the content), initializes and optimizes a 3-D
// input; returns the optimized poses by id. *summary (optional) receives the
// solver summary. A solve that stops without converging is not an error here;
// check summary->converged.
StatusOr<core::OptimizedPoses3d> SolvePoses3dFile(const std::string& path,
                                                  const core::SolverOptions& options,
                                                  core::SolverSummary* summary = nullptr);

// Runs the 3-D solve for RunSolveCommand once the input is known to be 3-D.
// Returns the process exit code.
int RunSolve3dCommand(const SolveCommandOptions& options, storage::InputFormat format,
                      core::LinearSolverType solver, core::PreconditionerType preconditioner);

}  // namespace graphslam::tools
