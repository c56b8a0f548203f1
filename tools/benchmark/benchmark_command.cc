#include "tools/benchmark/benchmark_command.h"

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "core/logging.h"
#include "tools/benchmark/scaling_report.h"
#include "tools/benchmark/scaling_sweep.h"
#include "tools/exit_codes.h"
#include "tools/option_checks.h"

namespace graphslam::tools {
namespace {

// "1e6" or "1000000": a whole number of features, at least 100.
StatusOr<int64_t> ParseSize(const std::string& text) {
  char* end = nullptr;
  const double value = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || !std::isfinite(value) ||
      value != std::floor(value) || value < 100 || value > 1e10)
    return Status::InvalidArgument("--features: '" + text +
                                   "' is not a whole number of features in [100, 1e10] "
                                   "(e.g. 1e6 or 1000000)");
  return static_cast<int64_t>(value);
}

}  // namespace

void AddBenchmarkCommand(CLI::App* app, BenchmarkCommandOptions* options, int* exit_code) {
  CLI::App* benchmark = app->add_subcommand(
      "benchmark", "Scaling benchmark: simulate, ingest and solve growing sizes in one proportion");
  benchmark->add_option("-o,--output", options->output, "output folder (created if missing)")
      ->required();
  benchmark->add_option("--features", options->features,
                        "sizes in features, comma-separated (1e4,1e5,...)")
      ->delimiter(',')
      ->capture_default_str();
  benchmark->add_option("--poses-per-feature", options->poses_per_feature,
                        "poses per feature at every size (the proportion)")
      ->check(PositiveReal())
      ->capture_default_str();
  benchmark->add_option("--runs", options->runs, "runs per simulated campus")
      ->check(Integer(1, 1000))
      ->capture_default_str();
  benchmark->add_option("--seed", options->seed, "simulation seed")->capture_default_str();
  benchmark->add_option("--initialization", options->initialization,
                        "the solve's --initialization (default: the solve's own default)")
      ->check(CLI::IsMember({"auto", "incremental", "progressive", "odometry", "pose-graph"}));
  benchmark->add_flag("--keep-stores", options->keep_stores,
                      "keep every size's chunk store under DIR/.benchmark/");
  benchmark->add_flag("--resume", options->resume,
                      "keep the sizes a killed sweep finished and go on with the next");
  benchmark->add_flag("-q,--quiet", options->quiet, "no progress or table on the terminal");
  benchmark->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  benchmark->callback([options, exit_code]() { *exit_code = RunBenchmarkCommand(*options); });
}

int RunBenchmarkCommand(const BenchmarkCommandOptions& options) {
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  benchmark::ScalingSweepOptions sweep;
  sweep.output = options.output;
  for (const std::string& text : options.features) {
    StatusOr<int64_t> size = ParseSize(text);
    if (!size.ok()) {
      std::fprintf(stderr, "graphslam benchmark: %s\n", size.status().message().c_str());
      return kExitUsage;
    }
    sweep.features.push_back(*size);
  }
  sweep.proportion.poses_per_feature = options.poses_per_feature;
  sweep.proportion.runs = options.runs;
  sweep.proportion.seed = options.seed;
  sweep.proportion.initialization = options.initialization;
  sweep.keep_stores = options.keep_stores;
  sweep.resume = options.resume;
  sweep.quiet = options.quiet;
  std::vector<benchmark::ScalingRow> rows;
  if (Status status = benchmark::RunScalingSweep(sweep, &rows); !status.ok()) {
    std::fprintf(stderr, "graphslam benchmark: %s\n", status.ToString().c_str());
    return ExitCodeFor(status);
  }
  if (!options.quiet) {
    std::fprintf(stderr, "graphslam benchmark: %zu sizes in %s/scaling.csv, scaling.html\n",
                 rows.size(), options.output.c_str());
    for (const benchmark::ScalingQuantity& q : benchmark::ScalingQuantities(rows))
      if (q.fit.valid)
        std::fprintf(stderr, "  %-22s grows as N^%.2f\n", q.name.c_str(), q.fit.exponent);
  }
  return kExitOk;
}

}  // namespace graphslam::tools
