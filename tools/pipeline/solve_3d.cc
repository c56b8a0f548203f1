// Steps 4-7 of RunSolve for a 3-D file (SE(3) poses, 3-D points): read,
// chain the initial guess (core/initialization_3d.h), SolveGraphSlam3d with
// --checkpoint / --resume (docs/formats/solver_checkpoint.md, 3-D poses), and
// the same outputs and report keys as the 2-D steps (-o in the 3-D g2o
// records, --tum, --report). --features-csv and --initialization apply to
// 2-D only.
#include <memory>

#include <nlohmann/json.hpp>

#include "core/graphslam_solver_3d.h"
#include "core/initialization_3d.h"
#include "core/logging.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/env.h"
#include "storage/g2o_3d_writer.h"
#include "storage/solver_checkpoint.h"
#include "tools/exit_codes.h"
#include "tools/pipeline/solve_run.h"
#include "tools/progress_display.h"
#include "tools/solve_report.h"

namespace graphslam::tools {
namespace {

struct Solve3d {
  core::Problem3d problem;
  double read_seconds = 0;
  double initialize_seconds = 0;
  core::Checkpointing3d checkpointing;
  core::SolverCheckpoint3d resume_state;
  core::SolverSummary summary;
  core::InformationRepairs repairs;  // --repair-information
};

// Checkpoints: one durable file replaced after every iteration; --resume
// continues from it, bit-identical to an uninterrupted solve.
Status AttachCheckpoints(const SolveCommandOptions& options, Solve3d& s) {
  if (options.resume && storage::Env::Default()->FileExists(options.checkpoint)) {
    GS_ASSIGN_OR_RETURN(s.resume_state,
                        storage::ReadSolverCheckpoint3d(options.checkpoint, options.input));
    s.checkpointing.resume_from = &s.resume_state;
    GS_LOG(INFO, "resuming from %s after iteration %d (chi2 %.9g)", options.checkpoint.c_str(),
           s.resume_state.iterations, s.resume_state.chi2);
  } else if (options.resume) {
    GS_LOG(WARNING, "no checkpoint at %s yet: starting from the beginning",
           options.checkpoint.c_str());
  }
  if (!options.checkpoint.empty()) {
    s.checkpointing.callback = [&options](const core::SolverCheckpoint3d& checkpoint) {
      return storage::WriteSolverCheckpoint(storage::Env::Default(), options.checkpoint,
                                            options.input, checkpoint);
    };
  }
  return Status::Ok();
}

// Steps 4-6.
Status ReadInitializeSolve(SolveRun& run, const DetectedInput& file, Solve3d& s) {
  const SolveCommandOptions& options = run.options;
  GS_ASSIGN_OR_RETURN(s.problem, storage::ReadProblem3d(options.input, file.format,
                                                       options.repair_information ? &s.repairs
                                                                                  : nullptr));
  s.read_seconds = SecondsSince(run.start);
  const SolveClock::time_point initialize_start = SolveClock::now();
  GS_RETURN_IF_ERROR(core::InitializeProblem3d(&s.problem));
  s.initialize_seconds = SecondsSince(initialize_start);

  const std::unique_ptr<tbb::global_control> threads = LimitThreads(options.threads);
  ProgressDisplay display(!options.quiet);
  core::SolverOptions solver_options = run.request.solver;
  solver_options.progress = display.AsCallback();
  solver_options.iteration_callback = display.AsIterationCallback();
  GS_RETURN_IF_ERROR(AttachCheckpoints(options, s));
  // The observations in feature-complete chunks (the solver streams them).
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = options.chunk_observations;
  const partition::InMemoryChunkSource3d chunks(s.problem, chunking);
  GS_RETURN_IF_ERROR(
      core::SolveGraphSlam3d(solver_options, chunks, &s.problem, &s.summary, s.checkpointing));
  display.Finish();
  return Status::Ok();
}

nlohmann::json Report3d(const SolveRun& run, const Solve3d& s, const char* format_name,
                        double total_seconds) {
  const core::Problem3d& problem = s.problem;
  nlohmann::json report = SolverReport(run.options, s.summary, format_name, total_seconds);
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
                                 3 * s.summary.observations_used;
  report["unknowns"] = 6 * s.summary.unknown_poses +
                       3 * (s.summary.eliminated_features + s.summary.kept_features);
  report["stage_seconds"] = {{"read", s.read_seconds},
                             {"initialize", s.initialize_seconds},
                             {"progressive_initialization", 0.0},
                             {"optimize", s.summary.seconds}};
  if (run.options.repair_information)
    report["information_repairs"] = InformationRepairsReport(s.repairs);
  return report;
}

// Step 7.
Status WriteOutputs3d(const SolveRun& run, const Solve3d& s, const char* format_name) {
  const SolveOutputs& outputs = run.request.outputs;
  if (!outputs.g2o.empty()) GS_RETURN_IF_ERROR(storage::WriteG2o3d(s.problem, outputs.g2o));
  if (!outputs.tum.empty()) GS_RETURN_IF_ERROR(storage::WriteTum3d(s.problem, outputs.tum));
  const double total_seconds = SecondsSince(run.start);
  if (!outputs.report.empty())
    GS_RETURN_IF_ERROR(WriteReport(outputs.report, Report3d(run, s, format_name, total_seconds)));
  if (!run.options.quiet) {
    std::FILE* const out = SummaryStream(run.options);
    std::fprintf(out, "graphslam solve summary (3-D)\n");
    std::fprintf(out, "  input              %s (%s)\n", run.options.input.c_str(), format_name);
    std::fprintf(out, "  poses / features   %d / %d\n", s.problem.num_poses(),
                 s.problem.num_features());
    std::fprintf(out, "  relative poses     %zu\n", s.problem.relative_poses.size());
    std::fprintf(out, "  observations       %zu\n", s.problem.observations.size());
    if (run.options.repair_information) PrintInformationRepairs(out, s.repairs);
    PrintSolverSummaryLines(out, s.summary, total_seconds);
  }
  return Status::Ok();
}

}  // namespace

int RunSolve3d(SolveRun& run, const DetectedInput& file) {
  if (!run.options.features_csv.empty())
    GS_LOG(WARNING, "--features-csv is ignored for 3-D inputs");
  Solve3d s;
  if (Status status = ReadInitializeSolve(run, file, s); !status.ok()) return run.Fail(status);
  const char* format_name = storage::InputFormatName(file.format);
  if (Status status = WriteOutputs3d(run, s, format_name); !status.ok()) return run.Fail(status);
  return s.summary.converged ? kExitOk : kExitNotConverged;
}

}  // namespace graphslam::tools
