#include "tools/solve_3d_command.h"

#include <tbb/global_control.h>
#include <tbb/info.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>

#include "core/graphslam_solver_3d.h"
#include "core/initialization_3d.h"
#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/g2o_3d_reader.h"
#include "storage/g2o_3d_writer.h"
#include "storage/isam_3d_reader.h"
#include "tools/exit_codes.h"
#include "tools/progress_display.h"
#include "tools/resource_usage.h"

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
  nlohmann::json report;
  report["input"] = options.input;
  report["format"] = format_name;
  report["dimension"] = 3;
  report["solver"] = core::LinearSolverName(summary.linear_solver_used);
  report["preconditioner"] = options.preconditioner;
  report["initial_chi2"] = summary.initial_chi2;
  report["final_chi2"] = summary.final_chi2;
  report["iterations"] = summary.iterations;
  report["converged"] = summary.converged;
  report["termination"] = summary.termination;
  report["poses"] = problem.num_poses();
  report["features"] = problem.num_features();
  report["observations"] = static_cast<int64_t>(problem.observations.size());
  report["observations_used"] = summary.observations_used;
  report["eliminated_features"] = summary.eliminated_features;
  report["kept_features"] = summary.kept_features;
  report["robust_kernel"] = "none";
  report["initialization"] = "odometry";
  report["resumed_from_iteration"] = 0;
  report["excluded_features"] = summary.excluded_features;
  report["unobserved_features"] = summary.unobserved_features;
  report["relative_pose_constraints"] = static_cast<int64_t>(problem.relative_poses.size());
  report["motion_constraints"] = 0;
  report["gps_constraints"] = static_cast<int64_t>(problem.gps.size());
  report["residual_dimension"] = 6 * static_cast<int64_t>(problem.relative_poses.size()) +
                                 3 * static_cast<int64_t>(problem.gps.size()) +
                                 3 * summary.observations_used;
  report["unknowns"] = 6 * summary.unknown_poses + 3 * summary.eliminated_features;
  report["reduced_nonzero_blocks"] = summary.reduced_nonzero_blocks;
  report["threads"] = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  report["seconds"] = total_seconds;
  report["stage_seconds"] = {{"read", read_seconds},
                             {"initialize", initialize_seconds},
                             {"progressive_initialization", 0.0},
                             {"optimize", summary.seconds}};
  report["peak_rss_bytes"] = PeakRssBytes();
  nlohmann::json per_iteration = nlohmann::json::array();
  for (const core::IterationSummary& it : summary.per_iteration) {
    per_iteration.push_back({{"iteration", it.iteration},
                             {"chi2", it.chi2},
                             {"candidate_chi2", it.candidate_chi2},
                             {"step_norm", it.step_norm},
                             {"gradient_max_norm", it.gradient_max_norm},
                             {"linear_solver_iterations", it.linear_iterations},
                             {"lambda", it.lambda},
                             {"relative_decrease", it.relative_decrease},
                             {"accepted", it.accepted},
                             {"seconds", it.seconds},
                             {"reduce_seconds", it.reduce_seconds},
                             {"solve_seconds", it.solve_seconds},
                             {"recover_seconds", it.recover_seconds}});
  }
  report["per_iteration"] = per_iteration;
  return report;
}

}  // namespace

StatusOr<core::Problem3d> ReadProblem3d(const std::string& path, storage::InputFormat format) {
  switch (format) {
    case storage::InputFormat::kG2o: return storage::ReadG2o3d(path);
    case storage::InputFormat::kIsam: return storage::ReadIsam3d(path);
    default: break;
  }
  return Status::NotSupported(path + ": format " + storage::InputFormatName(format) +
                              " has no 3-D reader; expected g2o or isam");
}

StatusOr<core::OptimizedPoses3d> SolvePoses3dFile(const std::string& path,
                                                  const core::SolverOptions& options,
                                                  core::SolverSummary* summary) {
  GS_ASSIGN_OR_RETURN(const storage::InputFormat format, storage::DetectInputFormat(path));
  GS_ASSIGN_OR_RETURN(core::Problem3d problem, ReadProblem3d(path, format));
  GS_RETURN_IF_ERROR(core::InitializeProblem3d(&problem));
  core::SolverSummary local;
  GS_RETURN_IF_ERROR(core::SolveGraphSlam3d(options, &problem, summary ? summary : &local));
  return core::ExtractOptimizedPoses(problem);
}

int RunSolve3dCommand(const SolveCommandOptions& options, storage::InputFormat format,
                      core::LinearSolverType solver, core::PreconditionerType preconditioner) {
  const Clock::time_point start = Clock::now();
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam solve: %s\n", status.ToString().c_str());
    return ExitCodeFor(status);
  };
  if (!options.features_csv.empty() || options.resume || !options.checkpoint.empty() ||
      options.robust_kernel != "none") {
    GS_LOG(WARNING, "--features-csv, --checkpoint, --resume and --robust-kernel are ignored for "
                    "3-D inputs");
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
  solver_options.max_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.initial_trust_region_radius = options.initial_trust_region_radius;
  solver_options.progress = display.AsCallback();
  core::SolverSummary summary;
  if (Status status = core::SolveGraphSlam3d(solver_options, &problem, &summary); !status.ok())
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
    std::printf("graphslam solve summary (3-D)\n");
    std::printf("  input              %s (%s)\n", options.input.c_str(), format_name);
    std::printf("  poses / features   %d / %d\n", problem.num_poses(), problem.num_features());
    std::printf("  relative poses     %zu\n", problem.relative_poses.size());
    std::printf("  observations       %zu\n", problem.observations.size());
    std::printf("  linear solver      %s\n", core::LinearSolverName(summary.linear_solver_used));
    std::printf("  initial chi2       %.9g\n", summary.initial_chi2);
    std::printf("  final chi2         %.9g\n", summary.final_chi2);
    std::printf("  iterations         %d (%s)\n", summary.iterations, summary.termination.c_str());
    std::printf("  seconds            %.3f\n", total_seconds);
    std::printf("  peak RSS           %.1f MiB\n", PeakRssBytes() / (1024.0 * 1024.0));
  }
  return summary.converged ? kExitOk : kExitNotConverged;
}

}  // namespace graphslam::tools
