// The 3-D hooks of the solve path (tools/pipeline/solve_path.h: Hooks3d) for a
// file of SE(3) poses and 3-D points: read, chain the initial guess
// (core/initialization_3d.h), SolveGraphSlam3d on in-memory chunks with
// --checkpoint / --resume (docs/formats/solver_checkpoint.md, 3-D poses).
// Everything else is the shared path: the same outputs (-o in the 3-D g2o
// records, --tum, --features-csv with a z column, --report with the same
// keys plus "dimension": 3) and the same summary. --initialization applies
// to 2-D only.
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "core/graphslam_solver_3d.h"
#include "core/initialization_3d.h"
#include "core/logging.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/env.h"
#include "storage/features_csv_writer.h"
#include "storage/g2o_3d_writer.h"
#include "storage/solver_checkpoint.h"
#include "tools/pipeline/solve_path.h"
#include "tools/pipeline/solve_run.h"

namespace graphslam::tools {
namespace {

struct Solve3d : SolveState<core::Space3d> {
  std::unique_ptr<partition::InMemoryChunkSource3d> in_memory;
  core::Checkpointing3d checkpointing;
};

struct Hooks3d {
  using Space = core::Space3d;
  using State = Solve3d;
  static constexpr int kDimension = 3;

  static Status ReadInput(const SolveRun& run, const DetectedInput* file, Solve3d& s) {
    const SolveCommandOptions& options = run.options;
    GS_ASSIGN_OR_RETURN(s.problem,
                        storage::ReadProblem3d(options.input, file->format,
                                               options.repair_information ? &s.repairs : nullptr));
    s.format_name = storage::InputFormatName(file->format);
    s.num_observations = static_cast<int64_t>(s.problem.observations.size());
    s.read_seconds = SecondsSince(run.start);
    return Status::Ok();
  }
  static Status InitializeGuess(const SolveRun&, Solve3d& s) {
    const SolveClock::time_point initialize_start = SolveClock::now();
    GS_RETURN_IF_ERROR(core::InitializeProblem3d(&s.problem));
    s.initialize_seconds = SecondsSince(initialize_start);
    return Status::Ok();
  }
  // The observations in feature-complete chunks (the solver streams them).
  static Status ConfigureChunks(const SolveRun& run, Solve3d& s) {
    partition::ChunkingOptions chunking;
    chunking.max_observations_per_chunk = run.options.chunk_observations;
    s.in_memory = std::make_unique<partition::InMemoryChunkSource3d>(s.problem, chunking);
    s.chunks = s.in_memory.get();
    return Status::Ok();
  }
  static std::string DefaultCheckpointPath(const SolveRun&, const Solve3d&) { return ""; }
  static StatusOr<core::SolverCheckpoint3d> ReadCheckpoint(const std::string& path,
                                                          const std::string& input) {
    return storage::ReadSolverCheckpoint3d(path, input);
  }
  static Status ImproveGuess(const SolveRun&, Solve3d&) { return Status::Ok(); }
  static Status PrepareCheckpoints(const SolveRun&, Solve3d&) { return Status::Ok(); }
  static void SetResume(Solve3d& s) { s.checkpointing.resume_from = &s.resume_state; }
  static void SetCheckpointWriter(Solve3d& s, CheckpointWriter<Space> writer) {
    s.checkpointing.callback = std::move(writer);
  }
  static Status WriteCheckpoint(const Solve3d& s, const std::string& input,
                                const core::SolverCheckpoint3d& checkpoint) {
    return storage::WriteSolverCheckpoint(storage::Env::Default(), s.checkpoint_path, input,
                                          checkpoint);
  }
  static Status Optimize(const SolveRun&, Solve3d& s) {
    const double optimize_cpu_start = ProcessCpuSeconds();
    GS_RETURN_IF_ERROR(
        core::SolveGraphSlam3d(s.solver, *s.chunks, &s.problem, &s.summary, s.checkpointing));
    s.optimize_cpu_seconds = ProcessCpuSeconds() - optimize_cpu_start;
    s.display->Finish();
    return Status::Ok();
  }
  static Status WriteGraph(const Solve3d& s, const std::string& path) {
    return storage::WriteG2o3d(s.problem, path);
  }
  static Status WriteTrajectory(const Solve3d& s, const std::string& path) {
    return storage::WriteTum3d(s.problem, path);
  }
  static Status WriteFeatures(const Solve3d& s, const std::string& path) {
    return storage::WriteFeaturesCsv(s.problem, path, &s.summary.excluded);
  }
  // The chain of relative poses (core/initialization_3d.h) is the only start.
  static void AddReport(const SolveRun&, const Solve3d&, nlohmann::json* report) {
    (*report)["initialization"] = "odometry";
    (*report)["initialization_used"] = "odometry";
  }
  static void PrintCounts(std::FILE* out, const Solve3d& s) {
    std::fprintf(out, "  relative poses     %zu\n", s.problem.relative_poses.size());
  }
  static void PrintDetails(std::FILE*, const SolveRun&, const Solve3d&) {}
};

}  // namespace

int RunSolve3d(SolveRun& run, const DetectedInput& file) {
  return RunSolvePath<Hooks3d>(run, &file);
}

}  // namespace graphslam::tools
