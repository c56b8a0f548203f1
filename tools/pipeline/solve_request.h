// The application layer's input: what a front end (the `solve` command line,
// a job file's solver settings, a future MPI or Python front end) asks for,
// turned into one validated SolveRequest before anything is read or written.
//
//   SolverSettings  --MakeSolverOptions-->  core::SolverOptions
//       the linear solver, preconditioner and robust kernels by name, the
//       tolerances and PCG parameters as numbers (defaults: SolverOptions')
//   SolveCommandOptions  --MakeSolveRequest-->  SolveRequest
//       the input, its format (or detection), the initialization, the solver
//       options and the outputs, every value range and combination checked
//
// Every error MakeSolveRequest returns is a usage error (exit 1,
// tools/exit_codes.h): its message names the option ("--solver: unknown
// linear solver 'foo'; ...") and nothing has been touched on disk. The run
// itself (detect -> read -> initialize -> solve -> write) is
// tools/pipeline/solve_pipeline.h.
//
// THREAD SAFETY: pure functions (IsChunkStore looks at the input's folder).
// ALLOCATION: the request's strings.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "core/graphslam_solver.h"
#include "core/status.h"
#include "storage/format_detection.h"
#include "tools/solve_command.h"

namespace graphslam::tools {

// The solver settings every front end shares, as given (names, numbers).
struct SolverSettings {
  std::string linear_solver = "auto";      // auto, pcg, cholmod
  std::string preconditioner = "subgraph";  // core::ParsePreconditionerType
  // core::ApplyRobustKernelOption: "K" or TYPE=K, several separated by spaces.
  std::string robust_kernel = "none";
  int max_iterations = core::SolverOptions().max_iterations;
  double function_tolerance = core::SolverOptions().function_tolerance;
  double model_tolerance = core::SolverOptions().model_tolerance;
  // > 0: the radius; 0: by the linear solver (core/graphslam_solver.h).
  double initial_trust_region_radius = core::SolverOptions().initial_trust_region_radius;
  double pcg_eta_min = core::SolverOptions().pcg_relative_tolerance;
  double pcg_eta_max = core::SolverOptions().pcg_eta_max;
  int pcg_deflation = core::SolverOptions().pcg_deflation_poses;
  double pcg_truncation = core::SolverOptions().pcg_truncation;
  int64_t max_eliminated_observations = core::SolverOptions().max_eliminated_observations;
  bool two_pass = false;  // no fused recover + reduce pass (same results)
};

// How the front end names the settings parsed from text, for the messages
// ("--solver: ...", or "solver.linear_solver: ..." in a job file).
struct SolverSettingNames {
  std::string linear_solver = "--solver";
  std::string preconditioner = "--preconditioner";
  std::string robust_kernel = "--robust-kernel";
};

// InvalidArgument naming the setting when a name does not parse or a PCG
// parameter is out of its range.
StatusOr<core::SolverOptions> MakeSolverOptions(const SolverSettings& settings,
                                                const SolverSettingNames& names = {});

// The command line's solver settings.
SolverSettings SolverSettingsFrom(const SolveCommandOptions& options);

// --initialization (docs/cli.md): how the start is made.
enum class Initialization { kAuto, kIncremental, kProgressive, kOdometry, kPoseGraph, kAsGiven };

struct SolveOutputs {
  std::string g2o;           // -o
  std::string tum;           // --tum
  std::string features_csv;  // --features-csv
  std::string report;        // --report
};

struct SolveRequest {
  // The settings as given: the report quotes them, the run reads the rest
  // (checkpoint, workdir, streaming thresholds, association, ...).
  SolveCommandOptions options;
  std::optional<storage::InputFormat> format;  // empty: detect from the content
  Initialization initialization = Initialization::kAuto;
  core::SolverOptions solver;  // progress callbacks and checkpoints are the run's
  int64_t memory_limit_bytes = 0;  // 0: no limit
  SolveOutputs outputs;
};

StatusOr<SolveRequest> MakeSolveRequest(const SolveCommandOptions& options);

}  // namespace graphslam::tools
