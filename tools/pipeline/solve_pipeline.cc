#include "tools/pipeline/solve_pipeline.h"

#include <memory>
#include <string>

#include "core/graphslam_solver_3d.h"
#include "core/initialization_3d.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/chunk_store.h"
#include "storage/dimension_detection.h"
#include "tools/exit_codes.h"
#include "tools/output_paths.h"
#include "tools/pipeline/solve_run.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

// Step 2: under mpirun a chunk store is solved over the launched processes
// (docs/distributed.md); any other input is for one process.
Status StartDistributed(SolveRun& run) {
  const int launched = LaunchedProcesses();
  if (launched > 0 && storage::IsChunkStore(run.options.input)) {
    StatusOr<std::unique_ptr<DistributedSolveRun>> started =
        DistributedSolveRun::Start(run.options.petsc_options);
    if (started.ok()) {
      run.distributed = std::move(started).value();
    } else if (launched > 1) {
      return started.status();
    }  // else one launched process without MPI support: the usual solve
  } else if (launched > 1) {
    return Status::NotSupported(
        "under mpirun with " + std::to_string(launched) + " processes the input must be a "
        "chunk store (graphslam ingest INPUT -o STORE/), got " + run.options.input);
  }
  run.root = run.distributed == nullptr || run.distributed->rank() == 0;
  run.quiet = run.options.quiet || !run.root;
  if (!run.root) SetQuietLogging(true);
  return Status::Ok();
}

// Step 3 for a file solved in memory: --format or the content's, and whether
// it holds SE(3) poses.
StatusOr<DetectedInput> DetectFile(const SolveRequest& request) {
  DetectedInput detected;
  if (request.format) {
    detected.format = *request.format;
  } else {
    GS_ASSIGN_OR_RETURN(detected.format, storage::DetectInputFormat(request.options.input));
  }
  GS_ASSIGN_OR_RETURN(detected.three_d,
                      storage::IsThreeDimensional(request.options.input, detected.format));
  return detected;
}

}  // namespace

int SolveRun::Fail(const Status& status) {
  std::fprintf(stderr, "graphslam solve: %s\n", status.ToString().c_str());
  if (distributed != nullptr && distributed->size() > 1) distributed->Abort(ExitCodeFor(status));
  return ExitCodeFor(status);
}

std::unique_ptr<tbb::global_control> LimitThreads(int threads) {
  if (threads <= 0) return nullptr;
  return std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                               static_cast<size_t>(threads));
}

Status WriteReport(const std::string& path, const nlohmann::json& report) {
  return storage::WriteStringAtomically(storage::Env::Default(), path, report.dump(2) + "\n");
}

std::FILE* SummaryStream(const SolveCommandOptions& options) {
  return WritesToStandardOutput(options) ? stderr : stdout;
}

int RunSolve(const SolveRequest& request) {
  SolveRun run(request);
  const SolveCommandOptions& options = request.options;
  // Every output must be writable where it goes before hours of solving.
  if (Status status = CheckOutputPaths({{"-o", options.output_g2o},
                                        {"--tum", options.tum},
                                        {"--features-csv", options.features_csv},
                                        {"--report", options.report},
                                        {"--checkpoint", options.checkpoint},
                                        {"--workdir", options.workdir, /*folder=*/true}});
      !status.ok())
    return run.Fail(status);
  if (Status status = StartDistributed(run); !status.ok()) return run.Fail(status);
  // A chunk store, or a FILE ingested into --workdir, needs no detection:
  // it holds a 2-D problem in the native format.
  if (storage::IsChunkStore(options.input) || !options.workdir.empty())
    return RunSolve2d(run, nullptr);
  StatusOr<DetectedInput> detected = DetectFile(request);
  if (!detected.ok()) return run.Fail(detected.status());
  return detected->three_d ? RunSolve3d(run, *detected) : RunSolve2d(run, &*detected);
}

StatusOr<core::OptimizedPoses3d> SolvePoses3dFile(const std::string& path,
                                                  const core::SolverOptions& options,
                                                  core::SolverSummary* summary) {
  GS_ASSIGN_OR_RETURN(const storage::InputFormat format, storage::DetectInputFormat(path));
  GS_ASSIGN_OR_RETURN(core::Problem3d problem, storage::ReadProblem3d(path, format));
  GS_RETURN_IF_ERROR(core::InitializeProblem3d(&problem));
  core::SolverSummary local;
  const partition::InMemoryChunkSource3d chunks(problem, partition::ChunkingOptions());
  GS_RETURN_IF_ERROR(
      core::SolveGraphSlam3d(options, chunks, &problem, summary ? summary : &local));
  return core::ExtractOptimizedPoses(problem);
}

}  // namespace graphslam::tools
