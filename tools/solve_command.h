// `graphslam solve INPUT -o OUT.g2o ...`: read any supported input, initialize
// (paper Table 1), optimize (Tables 2-5), and write the optimized graph, the
// trajectory, the features and a JSON report. Outputs are written only after a
// successful solve, each atomically, so bad input never leaves a file behind.
#pragma once

#include <cstdint>
#include <string>

#include "core/graphslam_solver.h"
#include "tools/cli_fwd.h"

namespace graphslam::tools {

struct SolveCommandOptions {
  std::string input;
  std::string format = "auto";      // auto, g2o, isam, mrclam, native
  std::string output_g2o;           // -o
  std::string report;               // --report
  std::string tum;                  // --tum
  std::string features_csv;         // --features-csv
  std::string solver = "auto";      // auto, pcg, cholmod
  std::string preconditioner = "subgraph";  // for pcg: subgraph, block-jacobi, incomplete-cholesky
  double pcg_eta_max = core::SolverOptions().pcg_eta_max;  // loosest PCG forcing term
  // Tightest PCG forcing term (SolverOptions::pcg_relative_tolerance).
  double pcg_eta_min = core::SolverOptions().pcg_relative_tolerance;
  // PCG trajectory deflation: poses per aggregate, 0 off (SolverOptions).
  int pcg_deflation = core::SolverOptions().pcg_deflation_poses;
  // PCG truncation, a fraction of --function-tolerance (SolverOptions).
  double pcg_truncation = core::SolverOptions().pcg_truncation;
  int max_iterations = core::SolverOptions().max_iterations;
  double function_tolerance = core::SolverOptions().function_tolerance;
  // A rejected step's model decrease, relative to chi2 (SolverOptions).
  double model_tolerance = core::SolverOptions().model_tolerance;
  double initial_trust_region_radius = 0;  // 0: by the linear solver (1e8 / 1e4)
  int threads = 0;                  // 0: all cores
  int robot = 1;                    // MRCLAM robot number
  int64_t chunk_observations = 4096;
  int64_t max_eliminated_observations = 64;
  // none, huber[:c], cauchy[:c] (observations), or TYPE=K with TYPE one of
  // observation, odometry, motion, gps; several separated by spaces or commas
  // (core/robust_kernel.h ApplyRobustKernelOption).
  std::string robust_kernel = "none";
  std::string initialization = "auto";  // auto, progressive, odometry, pose-graph, as-given
  int64_t progressive_max_new_poses = 500;     // poses added per progressive stage
  std::string checkpoint;  // --checkpoint FILE (default STORE/checkpoint.json for stores)
  bool resume = false;     // --resume: continue from the checkpoint if there is one
  // Out of core (tools/out_of_core_solve.h, docs/out_of_core.md).
  std::string workdir;       // --workdir DIR: ingest FILE into the store DIR, solve from it
  std::string memory_limit;  // --memory-limit SIZE: bounds chunks in flight ("" = none)
  bool two_pass = false;     // --two-pass: no fused recover + reduce pass (same results)
  std::string petsc_options;  // --petsc-options: under mpirun, PETSc options ("-ksp_type cg")
  int64_t streaming_poses = 100'000;            // stores above: streaming initialization
  int64_t streaming_observations = 10'000'000;  // stores above: streaming initialization
  // --sample-observations: the streaming start's sample budget B (0: the
  // rule max(10^6, 24 x poses); partition/initialization/sampled_incremental_initialization.h).
  int64_t sample_observations = 0;
  // Data association (unknown correspondence, docs/association.md).
  bool associate = false;           // --associate
  double chi = 1e-3;                // --chi: accept pi_{j=k} > chi
  double association_radius = 5.0;  // --association-radius [m]
  // --association: "incremental" (the scan-by-scan pass, then the rounds) or
  // "batch" (the rounds alone).
  std::string association = "incremental";
  bool associate_incremental = false;  // --associate-incremental: same as --association incremental
  bool ignore_barcodes = false;     // --ignore-barcodes (MRCLAM)
  bool repair_information = false;  // --repair-information (core/information_repair.h)
  bool quiet = false;
  int verbosity = 0;
};

// Registers the subcommand on `app`; the callback runs the solve and stores
// the exit code in *exit_code.
void AddSolveCommand(CLI::App* app, SolveCommandOptions* options, int* exit_code);

// Whether an output is "-" (standard output): the summary then goes to
// stderr so that it does not mix with the output.
bool WritesToStandardOutput(const SolveCommandOptions& options);

// Runs a solve; returns the process exit code (tools/exit_codes.h).
int RunSolveCommand(const SolveCommandOptions& options);

}  // namespace graphslam::tools
