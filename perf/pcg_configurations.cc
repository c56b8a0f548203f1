// The reduced-system solver configurations side by side on one g2o file:
// CHOLMOD, and PCG with each preconditioner (block-Jacobi, subgraph,
// incomplete Cholesky), exact solves or the Eisenstat-Walker forcing sequence
// (eta_max 0.1, 0.03, 0.01 or 0.001), warm starts on or off, trajectory
// deflation over 5, 10, 20 or 40 poses per aggregate. Every run
// starts from the odometry guess (paper Table 1) and runs Levenberg-Marquardt to the default
// tolerances; one line per run: LM iterations, CG iterations, seconds per LM
// iteration, mean solve seconds per iteration, total seconds and final chi2.
// This is the measurement behind the defaults of core/reduced_system_solver.h
// (docs/benchmarks.md, issue 4).
//
//   build/bin/pcg_configurations FILE.g2o [filter] [threads]
//   (filter: only configurations whose name contains it, "" for all;
//   threads: TBB threads, default all cores). CPU seconds (user + system of
//   the process during the run) are printed beside the wall-clock ones: on a
//   shared, loaded machine they are the fairer figure with 1 thread.
#include <sys/resource.h>
#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/g2o_reader.h"

namespace graphslam {
namespace {

// User + system CPU seconds of this process so far.
double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

struct Configuration {
  std::string name;
  core::LinearSolverType type;
  core::PreconditionerType preconditioner;
  bool forcing;
  double eta_max;
  bool warm_start;
  int deflation_poses = 0;  // trajectory deflation (core/trajectory_deflation.h), 0: off
};

int Main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: pcg_configurations FILE.g2o [filter]\n");
    return 1;
  }
  const std::string filter = argc > 2 ? argv[2] : "";
  std::unique_ptr<tbb::global_control> threads;
  if (argc > 3 && std::atoi(argv[3]) > 0) {
    threads = std::make_unique<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                    std::atoi(argv[3]));
  }
  StatusOr<core::Problem2d> read = storage::ReadG2o(argv[1]);
  if (!read.ok()) {
    std::fprintf(stderr, "%s\n", read.status().ToString().c_str());
    return 2;
  }
  core::Problem2d original = std::move(read).value();
  if (Status status = core::InitializeProblem(&original); !status.ok()) {
    std::fprintf(stderr, "%s\n", status.ToString().c_str());
    return 2;
  }
  using core::LinearSolverType;
  using core::PreconditionerType;
  std::vector<Configuration> configurations = {
      {"cholmod", LinearSolverType::kCholmod, PreconditionerType::kBlockJacobi, false, 0.1, false},
      {"auto", LinearSolverType::kAuto, PreconditionerType::kSubgraph, true,
       core::SolverOptions().pcg_eta_max, true}};
  const std::pair<const char*, PreconditionerType> preconditioners[] = {
      {"block-jacobi", PreconditionerType::kBlockJacobi},
      {"subgraph", PreconditionerType::kSubgraph},
      {"incomplete-cholesky", PreconditionerType::kIncompleteCholesky}};
  for (const auto& [name, preconditioner] : preconditioners) {
    const std::string base = std::string("pcg/") + name;
    configurations.push_back({base + "/exact", LinearSolverType::kPcg, preconditioner, false, 0.1, false});
    configurations.push_back({base + "/exact+warm", LinearSolverType::kPcg, preconditioner, false, 0.1, true});
    configurations.push_back({base + "/eta0.1", LinearSolverType::kPcg, preconditioner, true, 0.1, false});
    configurations.push_back({base + "/eta0.1+warm", LinearSolverType::kPcg, preconditioner, true, 0.1, true});
    configurations.push_back({base + "/eta0.03+warm", LinearSolverType::kPcg, preconditioner, true, 0.03, true});
    configurations.push_back({base + "/eta0.01+warm", LinearSolverType::kPcg, preconditioner, true, 0.01, true});
    configurations.push_back({base + "/eta0.001+warm", LinearSolverType::kPcg, preconditioner, true, 0.001, true});
    for (const int poses : {5, 10, 20, 40}) {
      configurations.push_back({base + "/eta0.01+warm+deflation" + std::to_string(poses),
                                LinearSolverType::kPcg, preconditioner, true, 0.01, true, poses});
    }
  }
  std::printf("%-36s %6s %8s %10s %10s %10s %9s %9s %16s %s\n", "configuration", "LM it",
              "CG it", "s/iter", "reduce s/it", "solve s/it", "total s", "CPU s", "final chi2",
              "termination");
  for (const Configuration& c : configurations) {
    if (c.name.find(filter) == std::string::npos) continue;
    core::Problem2d problem = original;
    partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
    core::SolverOptions options;
    options.linear_solver = c.type;
    options.preconditioner = c.preconditioner;
    options.pcg_forcing_sequence = c.forcing;
    options.pcg_eta_max = c.eta_max;
    options.pcg_warm_start = c.warm_start;
    options.pcg_deflation_poses = c.deflation_poses;
    options.max_iterations = 200;
    core::SolverSummary summary;
    const double cpu_start = CpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    const Status status = core::SolveGraphSlam(options, chunks, &problem, &summary);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double cpu_seconds = CpuSeconds() - cpu_start;
    if (!status.ok()) {
      std::printf("%-36s failed: %s\n", c.name.c_str(), status.ToString().c_str());
      continue;
    }
    long long cg = 0;
    double iteration_seconds = 0, reduce_seconds = 0, solve_seconds = 0;
    for (const core::IterationSummary& it : summary.per_iteration) {
      cg += it.linear_iterations;
      iteration_seconds += it.seconds;
      reduce_seconds += it.reduce_seconds;
      solve_seconds += it.solve_seconds;
    }
    const double n = std::max<size_t>(1, summary.per_iteration.size());
    std::printf("%-36s %6d %8lld %10.4f %10.4f %10.4f %9.2f %9.2f %16.6f %s (%s)\n",
                c.name.c_str(), summary.iterations, cg, iteration_seconds / n,
                reduce_seconds / n, solve_seconds / n, seconds, cpu_seconds, summary.final_chi2,
                summary.termination.c_str(),
                core::LinearSolverName(summary.linear_solver_used));
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace
}  // namespace graphslam

int main(int argc, char** argv) { return graphslam::Main(argc, argv); }
