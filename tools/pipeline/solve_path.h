// Steps 4-7 of RunSolve (tools/pipeline/solve_pipeline.h) written once over
// the problem space (core/problem_space.h: Space2d, Space3d). A dimension's
// file gives the steps that differ as the static members of a Hooks class
// (tools/pipeline/solve_2d.cc: Hooks2d, solve_3d.cc: Hooks3d); the steps
// every solve takes alike are here:
//
//   RunSolvePath<Hooks>(run, file)
//     Hooks::ReadInput        the problem (2-D: a chunk store or a file)
//     Hooks::InitializeGuess  Table 1 (2-D: or as-given's check)
//     ConfigureSolver         threads, progress display, solver options;
//                             Hooks::ConfigureChunks: the chunk source (2-D:
//                             and the --memory-limit budget); the checkpoint
//                             and --resume's state (OpenCheckpoint)
//     Hooks::ImproveGuess     2-D: --initialization (odometry probe,
//                             incremental, progressive, pose-graph)
//     AttachCheckpoints       the resumed state, the per-iteration writer
//     Hooks::Optimize         the solve (2-D: or association, or the MPI solve)
//     WriteOutputs            -o, --tum, --features-csv, --report, the summary
//
// The report's keys and the summary's lines are the same for both
// dimensions (docs/cli.md, "The report"); Hooks::AddReport and
// Hooks::PrintCounts / PrintDetails add a dimension's own.
//
// Hooks (Space, State derived from SolveState<Space>, kDimension, and):
//   Status ReadInput(const SolveRun&, const DetectedInput*, State&);
//   Status InitializeGuess(const SolveRun&, State&);
//   Status ConfigureChunks(const SolveRun&, State&);   // sets s.chunks
//   std::string DefaultCheckpointPath(const SolveRun&, const State&);
//   Status ImproveGuess(const SolveRun&, State&);
//   Status PrepareCheckpoints(const SolveRun&, State&);  // before the writer
//   void SetResume(State&);                              // s.resume_state
//   void SetCheckpointWriter(State&, CheckpointWriter<Space>);
//   Status WriteCheckpoint(const State&, const std::string& input,
//                          const CheckpointOf<Space>&);
//   Status Optimize(const SolveRun&, State&);
//   StatusOr<CheckpointOf<Space>> ReadCheckpoint(path, input);
//   Status WriteGraph / WriteTrajectory / WriteFeatures(const State&, path);
//   void AddReport(const SolveRun&, const State&, nlohmann::json*);
//   void PrintCounts(FILE*, const State&);   // after poses / features
//   void PrintDetails(FILE*, const SolveRun&, const State&);  // after observations
//
// THREAD SAFETY: main thread only. ALLOCATION: what the state holds.
#pragma once

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "core/chunk_source.h"
#include "core/graphslam_solver.h"
#include "core/information_repair.h"
#include "core/logging.h"
#include "core/problem_space.h"
#include "storage/env.h"
#include "tools/exit_codes.h"
#include "tools/pipeline/solve_run.h"
#include "tools/progress_display.h"
#include "tools/resource_usage.h"
#include "tools/solve_report.h"

namespace graphslam::tools {

template <class Space>
using CheckpointOf = core::BasicSolverCheckpoint<typename Space::Pose, typename Space::Point>;
template <class Space>
using CheckpointWriter = std::function<Status(const CheckpointOf<Space>&)>;

// What every solve holds, in the order the steps fill it; a dimension's
// state derives from it and adds its own.
template <class Space>
struct SolveState {
  typename Space::Problem problem;
  const char* format_name = "chunk-store";
  core::InformationRepairs repairs;  // --repair-information
  bool streaming = false;  // 2-D: observations stay on disk; the ingest's guess starts
  int64_t num_observations = 0;
  double read_seconds = 0, initialize_seconds = 0, progressive_seconds = 0;
  double initialization_cpu_seconds = 0;  // of the initializer that improved the guess
  double optimize_cpu_seconds = 0;
  double input_chi2 = std::numeric_limits<double>::quiet_NaN();  // the input's own estimate

  std::unique_ptr<tbb::global_control> threads;
  const core::BasicChunkSource<typename Space::Observation>* chunks = nullptr;
  std::unique_ptr<ProgressDisplay> display;
  core::SolverOptions solver;
  std::string checkpoint_path;
  CheckpointOf<Space> resume_state;
  bool resuming = false;

  core::SolverSummary summary;
};

// The checkpoint to write (--checkpoint, or the hook's default) and, with
// --resume, the state to continue from (one durable file, replaced
// atomically after every iteration; --resume continues from it bit-identical
// to an uninterrupted solve). Under mpirun rank 0 reads it and broadcasts it
// (docs/distributed.md).
template <class Hooks>
Status OpenCheckpoint(const SolveRun& run, typename Hooks::State& s) {
  const SolveCommandOptions& options = run.options;
  s.checkpoint_path = options.checkpoint;
  if (s.checkpoint_path.empty()) s.checkpoint_path = Hooks::DefaultCheckpointPath(run, s);
  s.resuming =
      run.root && options.resume && storage::Env::Default()->FileExists(s.checkpoint_path);
  if (s.resuming) {
    GS_ASSIGN_OR_RETURN(s.resume_state, Hooks::ReadCheckpoint(s.checkpoint_path, options.input));
    GS_LOG(INFO, "resuming from %s after iteration %d (chi2 %.9g)", s.checkpoint_path.c_str(),
           s.resume_state.iterations, s.resume_state.chi2);
  } else if (options.resume && run.root) {
    GS_LOG(WARNING, "no checkpoint at %s yet: starting from the beginning",
           s.checkpoint_path.c_str());
  }
  return Status::Ok();
}

// The chunks, the solver options, and the checkpoint to write or resume from.
template <class Hooks>
Status ConfigureSolver(const SolveRun& run, typename Hooks::State& s) {
  s.threads = LimitThreads(run.options.threads);
  s.display = std::make_unique<ProgressDisplay>(!run.quiet);
  s.solver = run.request.solver;
  s.solver.progress = s.display->AsCallback();
  s.solver.iteration_callback = s.display->AsIterationCallback();
  GS_RETURN_IF_ERROR(Hooks::ConfigureChunks(run, s));
  return OpenCheckpoint<Hooks>(run, s);
}

template <class Hooks>
Status AttachCheckpoints(const SolveRun& run, typename Hooks::State& s) {
  if (s.resuming) {
    // The solve continues from these estimates: moved into the problem, not
    // held twice (a feature's estimate for the whole solve).
    if (s.resume_state.features.size() == s.problem.features.size() &&
        !s.problem.features.empty()) {
      s.problem.features = std::move(s.resume_state.features);
      s.resume_state.features = {};
    }
    Hooks::SetResume(s);
  }
  if (s.checkpoint_path.empty()) return Status::Ok();
  GS_RETURN_IF_ERROR(Hooks::PrepareCheckpoints(run, s));
  const std::string& input = run.options.input;
  Hooks::SetCheckpointWriter(s, [&s, &input](const CheckpointOf<typename Hooks::Space>& c) {
    return Hooks::WriteCheckpoint(s, input, c);
  });
  return Status::Ok();
}

// The constraints that are not observations, by kind (0 where a dimension
// has none).
struct PoseConstraintCounts {
  int64_t relative_poses = 0, motions = 0, gps = 0, robot_sightings = 0;
};
template <class Problem>
PoseConstraintCounts CountPoseConstraints(const Problem& problem) {
  PoseConstraintCounts counts;
  counts.relative_poses = static_cast<int64_t>(problem.relative_poses.size());
  counts.gps = static_cast<int64_t>(problem.gps.size());
  if constexpr (requires { problem.motions; })
    counts.motions = static_cast<int64_t>(problem.motions.size());
  if constexpr (requires { problem.pose_range_bearings; })
    counts.robot_sightings = static_cast<int64_t>(problem.pose_range_bearings.size());
  return counts;
}

// The report's keys every solve gives (docs/cli.md, "The report").
template <class Hooks>
nlohmann::json SolveReport(const SolveRun& run, const typename Hooks::State& s,
                           double total_seconds) {
  using Space = typename Hooks::Space;
  const core::SolverSummary& summary = s.summary;
  nlohmann::json report = SolverReport(run.options, summary, s.format_name, total_seconds);
  if (Hooks::kDimension != 2) report["dimension"] = Hooks::kDimension;
  report["poses"] = s.problem.num_poses();
  report["features"] = s.problem.num_features();
  report["observations"] = s.num_observations;
  const PoseConstraintCounts counts = CountPoseConstraints(s.problem);
  report["relative_pose_constraints"] = counts.relative_poses;
  report["motion_constraints"] = counts.motions;
  report["gps_constraints"] = counts.gps;
  report["robot_sighting_constraints"] = counts.robot_sightings;
  // Degrees of freedom: chi2 / (residual_dimension - unknowns) should be near 1
  // when the noise is what the model says. A relative pose and a motion
  // measure a whole pose, a GPS fix, a robot sighting and an observation a
  // position (2-D: range and bearing, or x and y).
  report["residual_dimension"] =
      Space::kPoseDim * (counts.relative_poses + counts.motions) +
      Space::kFeatureDim * (counts.gps + counts.robot_sightings + summary.observations_used);
  report["unknowns"] = Space::kPoseDim * summary.unknown_poses +
                       Space::kFeatureDim * (summary.eliminated_features + summary.kept_features);
  report["stage_seconds"] = {{"read", s.read_seconds},
                             {"initialize", s.initialize_seconds},
                             {"progressive_initialization", s.progressive_seconds},
                             {"optimize", summary.seconds}};
  report["streaming"] = s.streaming;
  if (std::isfinite(s.input_chi2)) report["input_chi2"] = s.input_chi2;
  // CPU seconds (user + system, all threads) of the optimization and of the
  // whole process so far: on a shared machine the cost, where wall time
  // also counts the waits for a core.
  report["optimize_cpu_seconds"] = s.optimize_cpu_seconds;
  // Of the incremental, progressive or pose-graph initialization (its wall
  // time is stage_seconds.progressive_initialization).
  report["initialization_cpu_seconds"] = s.initialization_cpu_seconds;
  report["cpu_seconds"] = ProcessCpuSeconds();
  report["chunks_in_flight"] = s.solver.max_chunks_in_flight;
  report["memory_limit_bytes"] = run.request.memory_limit_bytes;
  if (run.options.repair_information)
    report["information_repairs"] = InformationRepairsReport(s.repairs);
  Hooks::AddReport(run, s, &report);
  return report;
}

template <class Hooks>
void PrintSummary(const SolveRun& run, const typename Hooks::State& s, double total_seconds) {
  const SolveCommandOptions& options = run.options;
  std::FILE* const out = SummaryStream(options);
  std::fprintf(out, "graphslam solve summary%s\n", Hooks::kDimension == 2 ? "" : " (3-D)");
  std::fprintf(out, "  input              %s (%s)\n", options.input.c_str(), s.format_name);
  std::fprintf(out, "  poses / features   %d / %d (%lld eliminated, %lld excluded)\n",
               s.problem.num_poses(), s.problem.num_features(),
               static_cast<long long>(s.summary.eliminated_features),
               static_cast<long long>(s.summary.excluded_features));
  Hooks::PrintCounts(out, s);
  std::fprintf(out, "  observations       %lld%s\n", static_cast<long long>(s.num_observations),
               s.streaming ? " (streamed from disk)" : "");
  Hooks::PrintDetails(out, run, s);
  if (options.repair_information) PrintInformationRepairs(out, s.repairs);
  if (std::isfinite(s.input_chi2))
    std::fprintf(out, "  input chi2         %.9g (the input's own estimate)\n", s.input_chi2);
  PrintSolverSummaryLines(out, s.summary, total_seconds);
}

// Each output atomically, after a successful solve; under mpirun rank 0 only.
template <class Hooks>
Status WriteOutputs(const SolveRun& run, const typename Hooks::State& s) {
  const SolveOutputs& outputs = run.request.outputs;
  if (!outputs.g2o.empty()) GS_RETURN_IF_ERROR(Hooks::WriteGraph(s, outputs.g2o));
  if (!outputs.tum.empty()) GS_RETURN_IF_ERROR(Hooks::WriteTrajectory(s, outputs.tum));
  if (!outputs.features_csv.empty())
    GS_RETURN_IF_ERROR(Hooks::WriteFeatures(s, outputs.features_csv));
  const double total_seconds = SecondsSince(run.start);
  if (!outputs.report.empty())
    GS_RETURN_IF_ERROR(WriteReport(outputs.report, SolveReport<Hooks>(run, s, total_seconds)));
  if (!run.quiet) PrintSummary<Hooks>(run, s, total_seconds);
  return Status::Ok();
}

template <class Hooks>
Status SolvePath(const SolveRun& run, const DetectedInput* file, typename Hooks::State& s) {
  GS_RETURN_IF_ERROR(Hooks::ReadInput(run, file, s));
  GS_RETURN_IF_ERROR(Hooks::InitializeGuess(run, s));
  GS_RETURN_IF_ERROR(ConfigureSolver<Hooks>(run, s));
  GS_RETURN_IF_ERROR(Hooks::ImproveGuess(run, s));
  GS_RETURN_IF_ERROR(AttachCheckpoints<Hooks>(run, s));
  GS_RETURN_IF_ERROR(Hooks::Optimize(run, s));
  return run.root ? WriteOutputs<Hooks>(run, s) : Status::Ok();
}

// Steps 4-7 and the exit code: 0 converged, 4 stopped unconverged, or the
// failure's (printed once, tools/exit_codes.h).
template <class Hooks>
int RunSolvePath(SolveRun& run, const DetectedInput* file) {
  typename Hooks::State s;
  if (Status status = SolvePath<Hooks>(run, file, s); !status.ok()) return run.Fail(status);
  return s.summary.converged ? kExitOk : kExitNotConverged;
}

}  // namespace graphslam::tools
