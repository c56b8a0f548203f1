// `graphslam benchmark -o DIR [--features N,N,...]`: the scaling benchmark
// (tools/benchmark/scaling_sweep.h) as a subcommand: every size simulated,
// ingested and solved to convergence with default options, in one
// proportion; results in DIR/scaling.csv and DIR/scaling.html with fitted
// exponents; `--resume` continues a killed sweep (docs/cli.md).
#pragma once

#include <string>
#include <vector>

#include "tools/cli_fwd.h"

namespace graphslam::tools {

struct BenchmarkCommandOptions {
  std::string output;
  std::vector<std::string> features = {"1e4", "1e5", "1e6", "1e7", "1e8"};
  double poses_per_feature = 0.01;
  int runs = 2;
  unsigned seed = 1;
  std::string initialization;  // the solve's --initialization ("": its default)
  bool keep_stores = false;
  bool resume = false;
  bool quiet = false;
  int verbosity = 0;
};

void AddBenchmarkCommand(CLI::App* app, BenchmarkCommandOptions* options, int* exit_code);

int RunBenchmarkCommand(const BenchmarkCommandOptions& options);

}  // namespace graphslam::tools
