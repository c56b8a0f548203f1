#include "tools/solve_3d_command.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/graphslam_solver_3d.h"
#include "core/initialization_3d.h"
#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/g2o_3d_reader.h"
#include "storage/g2o_3d_writer.h"
#include "storage/isam_3d_reader.h"
#include "storage/toro_reader.h"
#include "partition/in_memory_chunk_source.h"
#include "storage/solver_checkpoint.h"
#include "tools/exit_codes.h"
#include "tools/progress_display.h"
#include "tools/resource_usage.h"
#include "tools/solve_report.h"

namespace graphslam::tools {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

nlohmann::json BuildReport3d(const SolveCommandOptions& options, const core::Problem3d& problem,
                             const core::SolverSummary& summary, const char* format_name,
                             double read_seconds, double initialize_seconds,
                             double total_seconds) {
  nlohmann::json report = SolverReport(options, summary, format_name, total_seconds);
  report["dimension"] = 3;
  report["poses"] = problem.num_poses();
  report["features"] = problem.num_features();
  report["observations"] = static_cast<int64_t>(problem.observations.size());
  report["initialization"] = "odometry";
  report["relative_pose_constraints"] = static_cast<int64_t>(problem.relative_poses.size());
  report["motion_constraints"] = 0;
  report["gps_constraints"] = static_cast<int64_t>(problem.gps.size());
  report["residual_dimension"] = 6 * static_cast<int64_t>(problem.relative_poses.size()) +
                                 3 * static_cast<int64_t>(problem.gps.size()) +
                                 3 * summary.observations_used;
  report["unknowns"] =
      6 * summary.unknown_poses + 3 * (summary.eliminated_features + summary.kept_features);
  report["stage_seconds"] = {{"read", read_seconds},
                             {"initialize", initialize_seconds},
                             {"progressive_initialization", 0.0},
                             {"optimize", summary.seconds}};
  return report;
}

}  // namespace

StatusOr<core::Problem3d> ReadProblem3d(const std::string& path, storage::InputFormat format) {
  switch (format) {
    case storage::InputFormat::kG2o: return storage::ReadG2o3d(path);
    case storage::InputFormat::kIsam: return storage::ReadIsam3d(path);
    case storage::InputFormat::kToro: return storage::ReadToro3d(path);
    default: break;
  }
  return Status::NotSupported(path + ": format " + storage::InputFormatName(format) +
                              " has no 3-D reader; expected g2o, isam or toro");
}

StatusOr<core::OptimizedPoses3d> SolvePoses3dFile(const std::string& path,
                                                  const core::SolverOptions& options,
                                                  core::SolverSummary* summary) {
  GS_ASSIGN_OR_RETURN(const storage::InputFormat format, storage::DetectInputFormat(path));
  GS_ASSIGN_OR_RETURN(core::Problem3d problem, ReadProblem3d(path, format));
  GS_RETURN_IF_ERROR(core::InitializeProblem3d(&problem));
  core::SolverSummary local;
  const partition::InMemoryChunkSource3d chunks(problem, partition::ChunkingOptions());
  GS_RETURN_IF_ERROR(
      core::SolveGraphSlam3d(options, chunks, &problem, summary ? summary : &local));
  return core::ExtractOptimizedPoses(problem);
}

int RunSolve3dCommand(const SolveCommandOptions& options, storage::InputFormat format,
                      core::LinearSolverType solver, core::PreconditionerType preconditioner) {
  const Clock::time_point start = Clock::now();
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam solve: %s\n", status.ToString().c_str());
    return ExitCodeFor(status);
  };
  if (!options.features_csv.empty()) GS_LOG(WARNING, "--features-csv is ignored for 3-D inputs");
  core::RobustKernel observation_kernel;
  core::PoseFactorKernels pose_kernels;
  if (Status kernels = core::ApplyRobustKernelOption(options.robust_kernel, &observation_kernel,
                                                     &pose_kernels);
      !kernels.ok()) {
    std::fprintf(stderr, "graphslam solve: --robust-kernel: %s\n", kernels.ToString().c_str());
    return kExitUsage;
  }
  StatusOr<core::Problem3d> read = ReadProblem3d(options.input, format);
  if (!read.ok()) return fail(read.status());
  core::Problem3d problem = std::move(read).value();
  const double read_seconds = Seconds(start);
  const Clock::time_point initialize_start = Clock::now();
  if (Status status = core::InitializeProblem3d(&problem); !status.ok()) return fail(status);
  const double initialize_seconds = Seconds(initialize_start);

  std::unique_ptr<tbb::global_control> threads;
  if (options.threads > 0) {
    threads = std::make_unique<tbb::global_control>(
        tbb::global_control::max_allowed_parallelism, static_cast<size_t>(options.threads));
  }
  ProgressDisplay display(!options.quiet);
  core::SolverOptions solver_options;
  solver_options.linear_solver = solver;
  solver_options.preconditioner = preconditioner;
  solver_options.pcg_eta_max = options.pcg_eta_max;
  solver_options.pcg_deflation_poses = options.pcg_deflation;
  solver_options.pcg_truncation = options.pcg_truncation;
  solver_options.max_iterations = options.max_iterations;
  solver_options.max_eliminated_observations = options.max_eliminated_observations;
  solver_options.fused_chunk_pass = !options.two_pass;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.initial_trust_region_radius = options.initial_trust_region_radius;
  solver_options.observation_kernel = observation_kernel;
  solver_options.pose_kernels = pose_kernels;
  solver_options.progress = display.AsCallback();
  solver_options.iteration_callback = display.AsIterationCallback();
  // Checkpoints: one durable file replaced after every iteration; --resume
  // continues from it, bit-identical to an uninterrupted solve.
  core::Checkpointing3d checkpointing;
  core::SolverCheckpoint3d resume_state;
  if (options.resume && std::filesystem::exists(options.checkpoint)) {
    StatusOr<core::SolverCheckpoint3d> read_checkpoint =
        storage::ReadSolverCheckpoint3d(options.checkpoint, options.input);
    if (!read_checkpoint.ok()) return fail(read_checkpoint.status());
    resume_state = std::move(read_checkpoint).value();
    checkpointing.resume_from = &resume_state;
    GS_LOG(INFO, "resuming from %s after iteration %d (chi2 %.9g)", options.checkpoint.c_str(),
           resume_state.iterations, resume_state.chi2);
  } else if (options.resume) {
    GS_LOG(WARNING, "no checkpoint at %s yet: starting from the beginning",
           options.checkpoint.c_str());
  }
  if (!options.checkpoint.empty()) {
    checkpointing.callback = [&](const core::SolverCheckpoint3d& checkpoint) {
      return storage::WriteSolverCheckpoint(storage::Env::Default(), options.checkpoint,
                                            options.input, checkpoint);
    };
  }
  // The observations in feature-complete chunks (the solver streams them).
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = options.chunk_observations;
  const partition::InMemoryChunkSource3d chunks(problem, chunking);
  core::SolverSummary summary;
  if (Status status =
          core::SolveGraphSlam3d(solver_options, chunks, &problem, &summary, checkpointing);
      !status.ok())
    return fail(status);
  display.Finish();

  if (!options.output_g2o.empty()) {
    if (Status status = storage::WriteG2o3d(problem, options.output_g2o); !status.ok())
      return fail(status);
  }
  if (!options.tum.empty()) {
    if (Status status = storage::WriteTum3d(problem, options.tum); !status.ok())
      return fail(status);
  }
  const char* format_name = storage::InputFormatName(format);
  const double total_seconds = Seconds(start);
  if (!options.report.empty()) {
    const nlohmann::json report = BuildReport3d(options, problem, summary, format_name,
                                                read_seconds, initialize_seconds, total_seconds);
    if (Status status = storage::WriteStringAtomically(storage::Env::Default(), options.report,
                                                       report.dump(2) + "\n");
        !status.ok())
      return fail(status);
  }
  if (!options.quiet) {
    std::FILE* const out = WritesToStandardOutput(options) ? stderr : stdout;
    std::fprintf(out, "graphslam solve summary (3-D)\n");
    std::fprintf(out, "  input              %s (%s)\n", options.input.c_str(), format_name);
    std::fprintf(out, "  poses / features   %d / %d\n", problem.num_poses(), problem.num_features());
    std::fprintf(out, "  relative poses     %zu\n", problem.relative_poses.size());
    std::fprintf(out, "  observations       %zu\n", problem.observations.size());
    PrintSolverSummaryLines(out, summary, total_seconds);
  }
  return summary.converged ? kExitOk : kExitNotConverged;
}

}  // namespace graphslam::tools
