#include "tools/solve_command.h"

#include <CLI/CLI.hpp>
#include <cstdio>
#include <limits>

#include "core/logging.h"
#include "storage/atomic_file.h"
#include "tools/exit_codes.h"
#include "tools/option_checks.h"
#include "tools/pipeline/solve_pipeline.h"
#include "tools/pipeline/solve_request.h"

namespace graphslam::tools {

namespace {

// The linear solver, PCG and Levenberg-Marquardt settings.
void AddSolverOptions(CLI::App* solve, SolveCommandOptions* options) {
  solve->add_option("--solver", options->solver, "reduced system solver: auto, pcg, cholmod")
      ->capture_default_str();
  solve->add_option("--preconditioner", options->preconditioner,
                    "PCG preconditioner: block-jacobi, incomplete-cholesky, subgraph")
      ->capture_default_str();
  solve->add_option("--pcg-eta-min", options->pcg_eta_min,
                    "PCG: the tightest relative residual (the forcing sequence's floor, and the "
                    "tolerance of exact solves), in (0, --pcg-eta-max]")
      ->check(Real(0.0, 1.0, Bounds::kOpen))
      ->capture_default_str();
  solve->add_option("--pcg-eta-max", options->pcg_eta_max,
                    "PCG: the loosest relative residual of the forcing sequence, in (0, 1)")
      ->check(Real(1e-10, 1.0, Bounds::kOpenUpper))
      ->capture_default_str();
  solve->add_option("--pcg-deflation", options->pcg_deflation,
                    "PCG: deflate the trajectory's smooth error modes, in aggregates of this many "
                    "consecutive poses (constant and linear modes each); 0: off")
      ->check(Integer(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  solve->add_option("--pcg-truncation", options->pcg_truncation,
                    "PCG: stop a solve once the chi2 decrease it still misses is estimated below "
                    "this x --function-tolerance x chi2, in [0, 1); 0: off")
      ->check(Real(0.0, 1.0, Bounds::kOpenUpper))
      ->capture_default_str();
  solve->add_option("--max-iterations", options->max_iterations, "Levenberg-Marquardt iterations")
      ->check(Integer(0, std::numeric_limits<int>::max()))
      ->capture_default_str();
  solve->add_option("--function-tolerance", options->function_tolerance,
                    "stop when the relative chi2 decrease of a step (or the next one's, "
                    "extrapolated) is below this")
      ->check(Real(0.0, 1.0, Bounds::kOpenUpper))
      ->capture_default_str();
  solve->add_option("--model-tolerance", options->model_tolerance,
                    "stop when a rejected step's model decrease (the chi2 the quadratic model "
                    "still expects to gain) is below this x chi2; 0: only --function-tolerance")
      ->check(Real(0.0, 1.0, Bounds::kOpenUpper))
      ->capture_default_str();
  solve->add_option("--initial-trust-region", options->initial_trust_region_radius,
                    "initial trust region radius (1 / initial damping; default: 1e8 with "
                    "CHOLMOD, 1e4 with PCG)")
      ->check(Real(0.0, core::SolverOptions().max_trust_region_radius, Bounds::kOpenLower));
  solve->add_option("--threads", options->threads, "worker threads (0: all cores)")
      ->check(Integer(0, 65536))
      ->capture_default_str();
}

// The outputs besides -o, and how the problem is read and modelled.
void AddOutputAndModelOptions(CLI::App* solve, SolveCommandOptions* options) {
  solve->add_option("--report", options->report, "run report (.json)");
  solve->add_option("--tum", options->tum, "optimized trajectory (TUM format)");
  solve->add_option("--features-csv", options->features_csv, "optimized features (.csv)");
  solve->add_option("--robot", options->robot, "MRCLAM robot number")
      ->check(Integer(1, 5))
      ->capture_default_str();
  solve->add_option("--chunk-observations", options->chunk_observations,
                    "observations per chunk (feature-complete)")
      ->check(Integer(1))
      ->capture_default_str();
  solve->add_option("--max-eliminated-observations", options->max_eliminated_observations,
                    "features with more observations stay unknowns instead of being eliminated")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_option("--robust-kernel", options->robust_kernel,
                    "[TYPE=]K, K one of none, huber[:c], cauchy[:c]; TYPE one of observation "
                    "(the default), odometry, motion, gps; repeatable")
      ->join(' ')
      ->capture_default_str();
}

// The initial guess, checkpoints and the out-of-core solve.
void AddInitializationAndOutOfCoreOptions(CLI::App* solve, SolveCommandOptions* options) {
  solve->add_option("--initialization", options->initialization,
                    "initial guess: auto (odometry, then incremental if the first steps show "
                    "it is outside the optimum's basin; incremental at once with a checkpoint), "
                    "incremental (solve a window of recent poses per stage, linear in poses), "
                    "progressive (solve growing prefixes of the trajectory), "
                    "odometry (the paper's Table 1 only), pose-graph (Table 1, then the pose-only "
                    "problem solved and the features re-placed) or as-given (the input's guess "
                    "unchanged; every vertex must have one)")
      ->capture_default_str();
  solve->add_option("--progressive-max-new-poses", options->progressive_max_new_poses,
                    "at most this many poses join per progressive stage")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_option("--checkpoint", options->checkpoint,
                    "solver checkpoint file, replaced atomically after every iteration "
                    "(default for a chunk store: STORE/checkpoint.json)");
  solve->add_flag("--resume", options->resume,
                  "continue from the checkpoint, if one exists (after a crash or kill -9)");
  solve->add_option("--workdir", options->workdir,
                    "ingest a FILE input into this chunk store directory and solve from it "
                    "(kept afterwards; without it a FILE is solved in memory)");
  solve->add_option("--memory-limit", options->memory_limit,
                    "peak memory (e.g. 2G): refused at the start if below the estimated need; "
                    "bounds the chunks in flight, the CHOLMOD factor and the ingest buffer");
  solve->add_flag("--two-pass", options->two_pass,
                  "two passes over the observation chunks every iteration instead of one "
                  "fused pass (for measurements; same results)");
  solve->add_option("--streaming-poses", options->streaming_poses,
                    "stores with more poses skip progressive initialization (streaming mode)")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_option("--streaming-observations", options->streaming_observations,
                    "stores with more observations are solved without loading them (streaming mode)")
      ->check(Integer(0))
      ->capture_default_str();
  solve->add_option("--sample-observations", options->sample_observations,
                    "streaming mode: observations of the feature sample the start solves "
                    "(0: max(1e6, 24 x poses); at most what --memory-limit leaves)")
      ->check(Integer(0))
      ->capture_default_str();
}

// Unknown correspondence (docs/association.md).
void AddAssociationOptions(CLI::App* solve, SolveCommandOptions* options) {
  solve->add_flag("--associate", options->associate,
                  "unknown correspondence: merge features by the correspondence test "
                  "(paper Tables 9-10; docs/association.md)");
  solve->add_option("--chi", options->chi,
                    "with --associate: merge when the correspondence probability exceeds this")
      ->check(Real(0.0, 1.0))
      ->capture_default_str();
  solve->add_option("--association-radius", options->association_radius,
                    "with --associate: test feature pairs closer than this [m]")
      ->check(PositiveReal())
      ->capture_default_str();
  solve->add_option("--association", options->association,
                    "with --associate: incremental (pair each scan with the map so far: joint "
                    "compatibility, stage undo, loop closure by submap matching; then the "
                    "rounds) or batch (the rounds alone)")
      ->check(CLI::IsMember({"incremental", "batch"}))
      ->capture_default_str();
  solve->add_flag("--associate-incremental", options->associate_incremental,
                  "same as --association incremental (the default)");
  solve->add_flag("--ignore-barcodes", options->ignore_barcodes,
                  "MRCLAM: drop the landmark identities (use with --associate)");
}

}  // namespace

void AddSolveCommand(CLI::App* app, SolveCommandOptions* options, int* exit_code) {
  CLI::App* solve = app->add_subcommand(
      "solve",
      "Optimize one input (g2o, iSAM, TORO .graph, MRCLAM folder, native log, chunk store) and "
      "write the results");
  solve->add_option("input", options->input, "input file or MRCLAM dataset folder")->required();
  solve->add_option("-o,--output", options->output_g2o, "optimized graph (.g2o)");
  solve->add_option("--format", options->format, "input format: auto, g2o, isam, mrclam, native, toro")
      ->capture_default_str();
  AddSolverOptions(solve, options);
  AddOutputAndModelOptions(solve, options);
  AddInitializationAndOutOfCoreOptions(solve, options);
  AddAssociationOptions(solve, options);
  solve->add_option("--petsc-options", options->petsc_options,
                    "under mpirun: PETSc options for the reduced system's solve, e.g. "
                    "\"-ksp_type cg -pc_type gamg\" (PETSC_OPTIONS works too; docs/distributed.md)");
  solve->add_flag("--repair-information", options->repair_information,
                  "repair non-positive-definite information matrices (g2o, iSAM, native, "
                  "TORO; 2-D and 3-D) instead of rejecting the file");
  solve->add_flag("-q,--quiet", options->quiet, "no progress or summary on the terminal");
  solve->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  solve->callback([options, exit_code]() { *exit_code = RunSolveCommand(*options); });
}

bool WritesToStandardOutput(const SolveCommandOptions& options) {
  for (const std::string* path :
       {&options.output_g2o, &options.tum, &options.features_csv, &options.report})
    if (*path == storage::kStandardOutput) return true;
  return false;
}

int RunSolveCommand(const SolveCommandOptions& options) {
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  // A wrong command line is found before anything is read or written.
  StatusOr<SolveRequest> request = MakeSolveRequest(options);
  if (!request.ok()) {
    std::fprintf(stderr, "graphslam solve: %s\n", request.status().message().c_str());
    return kExitUsage;
  }
  return RunSolve(*request);
}

}  // namespace graphslam::tools
