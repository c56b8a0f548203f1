// Seconds per GraphSLAM iteration on real datasets (Victoria Park with
// landmarks, city10000, intel and M3500 pose graphs), per linear solver.
//
// Each benchmark run does what `graphslam solve` does by default after
// reading: progressive initialization, then the full Levenberg-Marquardt
// solve. Counters report the iteration count of the full solve, its seconds
// per iteration, the progressive stage's seconds and the final chi2 (g2o
// convention), so speed is always quoted with the optimum it reached.
//
//   build/bin/graphslam_solver_benchmark --benchmark_repetitions=3
//       --benchmark_out=docs/results/graphslam_solver.json   (one command line)
#include <benchmark/benchmark.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/initialization/progressive_initialization.h"
#include "storage/format_detection.h"

namespace graphslam {
namespace {

void BM_GraphSlamSolve(benchmark::State& state, const std::string& relative_path,
                       core::LinearSolverType solver) {
  const std::string path = std::string(GRAPHSLAM_DATASETS_DIR) + "/" + relative_path;
  if (!std::filesystem::exists(path)) {
    state.SkipWithError(("dataset missing: " + path).c_str());
    return;
  }
  StatusOr<storage::InputFormat> format = storage::DetectInputFormat(path);
  StatusOr<core::Problem2d> read = storage::ReadProblem(path, *format, storage::MrclamOptions());
  if (!read.ok()) {
    state.SkipWithError(read.status().ToString().c_str());
    return;
  }
  core::Problem2d original = std::move(read).value();
  if (Status status = core::InitializeProblem(&original); !status.ok()) {
    state.SkipWithError(status.ToString().c_str());
    return;
  }
  core::SolverSummary summary;
  partition::ProgressiveSummary progressive;
  for (auto _ : state) {
    core::Problem2d problem = original;
    core::SolverOptions options;
    options.linear_solver = solver;
    options.max_iterations = 200;
    Status status = partition::InitializeProgressively(partition::ProgressiveInitializationOptions(),
                                                       options, &problem, &progressive);
    if (!status.ok()) {
      state.SkipWithError(status.ToString().c_str());
      return;
    }
    partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
    status = core::SolveGraphSlam(options, chunks, &problem, &summary);
    if (!status.ok()) {
      state.SkipWithError(status.ToString().c_str());
      return;
    }
  }
  state.counters["iterations"] = summary.iterations;
  state.counters["seconds_per_iteration"] =
      summary.iterations > 0 ? summary.seconds / summary.iterations : 0.0;
  state.counters["final_chi2"] = summary.final_chi2;
  state.counters["progressive_seconds"] = progressive.seconds;
  state.counters["solve_seconds"] = summary.seconds;
  state.counters["initial_chi2"] = summary.initial_chi2;
}

#define GS_SOLVER_BENCHMARK(name, path)                                                   \
  BENCHMARK_CAPTURE(BM_GraphSlamSolve, name##_cholmod, path, core::LinearSolverType::kCholmod) \
      ->Unit(benchmark::kMillisecond)                                                     \
      ->Iterations(1);                                                                    \
  BENCHMARK_CAPTURE(BM_GraphSlamSolve, name##_pcg, path, core::LinearSolverType::kPcg)    \
      ->Unit(benchmark::kMillisecond)                                                     \
      ->Iterations(1)

GS_SOLVER_BENCHMARK(VictoriaPark, "victoria_park/victoriaPark-full.g2o");
GS_SOLVER_BENCHMARK(City10000, "sesync_posegraphs/city10000.g2o");
GS_SOLVER_BENCHMARK(Intel, "freiburg_course_g2o/intel.g2o");
GS_SOLVER_BENCHMARK(M3500, "freiburg_course_g2o/input_M3500_g2o.g2o");

}  // namespace
}  // namespace graphslam

int main(int argc, char** argv) {
#ifndef NDEBUG
  std::fprintf(stderr, "***WARNING*** assertions are enabled: timings are not representative\n");
#endif
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
