#include "tools/pipeline/solve_request.h"

#include <cstdio>
#include <string>

#include "partition/initialization/progressive_initialization.h"
#include "storage/chunk_store.h"
#include "tools/distributed_solve_command.h"
#include "tools/memory_size.h"

namespace graphslam::tools {
namespace {

Status Usage(const std::string& message) { return Status::InvalidArgument(message); }

std::string Number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", value);
  return text;
}

// `name`: `status`'s text, the way the command line has always printed a
// value it could not parse ("--format: InvalidArgument: input format 'xyz'; ...").
Status NamedError(const std::string& name, const Status& status) {
  return Usage(name + ": " + status.ToString());
}

// The PCG parameters' ranges (CLI11 checks each alone; these are the joint
// ones, and the whole check for front ends without CLI11).
Status CheckPcgSettings(const SolverSettings& s) {
  // The exact-solve tolerance (1e-10) is the tightest forcing term.
  if (!(s.pcg_eta_min > 0.0) || !(s.pcg_eta_min <= s.pcg_eta_max))
    return Usage("--pcg-eta-min must be in (0, --pcg-eta-max = " + Number(s.pcg_eta_max) +
                 "], got " + Number(s.pcg_eta_min));
  if (s.pcg_deflation < 0 || s.pcg_deflation == 1)
    return Usage("--pcg-deflation must be 0 (off) or >= 2 poses, got " +
                 std::to_string(s.pcg_deflation));
  if (!(s.pcg_truncation >= 0.0) || !(s.pcg_truncation < 1.0))
    return Usage("--pcg-truncation must be in [0, 1), got " + Number(s.pcg_truncation));
  if (!(s.pcg_eta_max >= core::SolverOptions().pcg_relative_tolerance) || !(s.pcg_eta_max < 1.0))
    return Usage("--pcg-eta-max must be in [1e-10, 1), got " + Number(s.pcg_eta_max));
  return Status::Ok();
}

// Counts, names and the combinations of options that cannot work together.
Status CheckCommandOptions(const SolveCommandOptions& options) {
  if (options.input.empty()) return Usage("no INPUT given");
  if (options.max_iterations < 0)
    return Usage("--max-iterations must be >= 0, got " + std::to_string(options.max_iterations));
  if (options.threads < 0)
    return Usage("--threads must be >= 0, got " + std::to_string(options.threads));
  if (options.max_eliminated_observations < 0)
    return Usage("--max-eliminated-observations must be >= 0");
  if (options.chunk_observations <= 0) return Usage("--chunk-observations must be > 0");
  const bool store_input = storage::IsChunkStore(options.input);
  if (options.resume && options.checkpoint.empty() && !store_input && options.workdir.empty())
    return Usage("--resume needs --checkpoint FILE (or a chunk store as input)");
  if (options.associate && (options.resume || !options.checkpoint.empty()))
    return Usage("--associate cannot be combined with --checkpoint/--resume");
  if (options.repair_information && !options.workdir.empty())
    return Usage("--repair-information cannot be combined with --workdir");
  if (options.associate && !options.workdir.empty())
    return Usage("--associate cannot be combined with --workdir (merges rewrite the in-memory "
                 "chunks only)");
  // Under mpirun a chunk store is solved over the launched processes
  // (docs/distributed.md), which do not associate.
  if (LaunchedProcesses() > 0 && store_input && options.associate)
    return Usage("under mpirun, --associate is not supported yet (docs/distributed.md)");
  partition::ProgressiveInitializationOptions progressive;
  progressive.max_observations_per_chunk = options.chunk_observations;
  progressive.max_new_poses = options.progressive_max_new_poses;
  return progressive.Validate();
}

StatusOr<Initialization> ParseInitialization(const std::string& name) {
  if (name == "auto") return Initialization::kAuto;
  if (name == "incremental") return Initialization::kIncremental;
  if (name == "progressive") return Initialization::kProgressive;
  if (name == "odometry") return Initialization::kOdometry;
  if (name == "pose-graph") return Initialization::kPoseGraph;
  if (name == "as-given") return Initialization::kAsGiven;
  return Usage("--initialization must be auto, incremental, progressive, odometry, pose-graph or "
               "as-given, got '" + name + "'");
}

}  // namespace

StatusOr<core::SolverOptions> MakeSolverOptions(const SolverSettings& settings,
                                                const SolverSettingNames& names) {
  core::SolverOptions options;
  StatusOr<core::LinearSolverType> solver = core::ParseLinearSolverType(settings.linear_solver);
  if (!solver.ok()) return NamedError(names.linear_solver, solver.status());
  StatusOr<core::PreconditionerType> preconditioner =
      core::ParsePreconditionerType(settings.preconditioner);
  if (!preconditioner.ok()) return NamedError(names.preconditioner, preconditioner.status());
  GS_RETURN_IF_ERROR(CheckPcgSettings(settings));
  if (Status kernels = core::ApplyRobustKernelOption(
          settings.robust_kernel, &options.observation_kernel, &options.pose_kernels);
      !kernels.ok())
    return NamedError(names.robust_kernel, kernels);
  options.linear_solver = *solver;
  options.preconditioner = *preconditioner;
  options.pcg_relative_tolerance = settings.pcg_eta_min;
  options.pcg_eta_max = settings.pcg_eta_max;
  options.pcg_deflation_poses = settings.pcg_deflation;
  options.pcg_truncation = settings.pcg_truncation;
  options.max_iterations = settings.max_iterations;
  options.function_tolerance = settings.function_tolerance;
  options.model_tolerance = settings.model_tolerance;
  options.initial_trust_region_radius = settings.initial_trust_region_radius;
  options.max_eliminated_observations = settings.max_eliminated_observations;
  options.fused_chunk_pass = !settings.two_pass;
  return options;
}

SolverSettings SolverSettingsFrom(const SolveCommandOptions& options) {
  SolverSettings settings;
  settings.linear_solver = options.solver;
  settings.preconditioner = options.preconditioner;
  settings.robust_kernel = options.robust_kernel;
  settings.max_iterations = options.max_iterations;
  settings.function_tolerance = options.function_tolerance;
  settings.model_tolerance = options.model_tolerance;
  settings.initial_trust_region_radius = options.initial_trust_region_radius;
  settings.pcg_eta_min = options.pcg_eta_min;
  settings.pcg_eta_max = options.pcg_eta_max;
  settings.pcg_deflation = options.pcg_deflation;
  settings.pcg_truncation = options.pcg_truncation;
  settings.max_eliminated_observations = options.max_eliminated_observations;
  settings.two_pass = options.two_pass;
  return settings;
}

StatusOr<SolveRequest> MakeSolveRequest(const SolveCommandOptions& options) {
  GS_RETURN_IF_ERROR(CheckCommandOptions(options));
  SolveRequest request;
  request.options = options;
  GS_ASSIGN_OR_RETURN(request.initialization, ParseInitialization(options.initialization));
  GS_ASSIGN_OR_RETURN(request.solver, MakeSolverOptions(SolverSettingsFrom(options)));
  if (options.format != "auto") {
    StatusOr<storage::InputFormat> format = storage::ParseInputFormat(options.format);
    if (!format.ok()) return NamedError("--format", format.status());
    request.format = *format;
  }
  if (!options.memory_limit.empty()) {
    StatusOr<int64_t> bytes = ParseMemorySize(options.memory_limit);
    if (!bytes.ok()) return NamedError("--memory-limit", bytes.status());
    request.memory_limit_bytes = *bytes;
  }
  request.outputs = {options.output_g2o, options.tum, options.features_csv, options.report};
  return request;
}

}  // namespace graphslam::tools
