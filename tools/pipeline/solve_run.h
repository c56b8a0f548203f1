// What the steps of one RunSolve share (tools/pipeline/solve_pipeline.h):
// the request, the clock, the MPI run if there is one, and how a failure
// ends the command. Internal to tools/pipeline.
//
// THREAD SAFETY: main thread only. ALLOCATION: none beyond the MPI run.
#pragma once

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>
#include <tbb/global_control.h>

#include "core/status.h"
#include "storage/format_detection.h"
#include "tools/distributed_solve_command.h"
#include "tools/pipeline/solve_request.h"

namespace graphslam::tools {

using SolveClock = std::chrono::steady_clock;

inline double SecondsSince(SolveClock::time_point since) {
  return std::chrono::duration<double>(SolveClock::now() - since).count();
}

struct SolveRun {
  explicit SolveRun(const SolveRequest& r) : request(r), options(r.options) {}

  const SolveRequest& request;
  const SolveCommandOptions& options;  // request.options
  const SolveClock::time_point start = SolveClock::now();
  // Under mpirun: this process's rank; rank 0 initializes, reports and writes.
  std::unique_ptr<DistributedSolveRun> distributed;
  bool root = true;
  bool quiet = false;

  // Prints "graphslam solve: STATUS" and returns its exit code; under
  // mpirun it ends every rank (the others may wait in a collective call).
  int Fail(const Status& status);
};

// A file input's format and dimension (not for chunk stores, which are 2-D).
struct DetectedInput {
  storage::InputFormat format = storage::InputFormat::kG2o;
  bool three_d = false;
};

// Steps 4-7 for each dimension (tools/pipeline/solve_path.h with the hooks
// of solve_2d.cc, solve_3d.cc); `file` is empty for a chunk store or a
// --workdir ingest.
int RunSolve2d(SolveRun& run, const DetectedInput* file);
int RunSolve3d(SolveRun& run, const DetectedInput& file);

// Shared by both: the worker thread limit, the report file, the summary's
// destination (stderr when an output goes to standard output).
std::unique_ptr<tbb::global_control> LimitThreads(int threads);  // 0: no limit
[[nodiscard]] Status WriteReport(const std::string& path, const nlohmann::json& report);
std::FILE* SummaryStream(const SolveCommandOptions& options);

}  // namespace graphslam::tools
