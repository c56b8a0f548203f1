// The graphslam command line: one binary, subcommands (docs/cli.md).
#include <CLI/CLI.hpp>

#include <cstdio>
#include <string>

#include "tools/benchmark/benchmark_command.h"
#include "tools/cli_errors.h"
#include "tools/evaluate_command.h"
#include "tools/exit_codes.h"
#include "tools/ingest_command.h"
#include "tools/map_command.h"
#include "tools/run_command.h"
#include "tools/simulate_command.h"
#include "tools/solve_command.h"
#include "tools/version.h"

int main(int argc, char** argv) {
  CLI::App app{"graphslam: offline GraphSLAM map builder (Thrun & Montemerlo)"};
  app.require_subcommand(1);
  std::string version = graphslam::tools::VersionText();
  version.pop_back();  // CLI11 adds the newline
  app.set_version_flag("--version", version, "the version, the build's commit and its libraries");
  int exit_code = graphslam::tools::kExitOk;
  graphslam::tools::SolveCommandOptions solve_options;
  graphslam::tools::AddSolveCommand(&app, &solve_options, &exit_code);
  graphslam::tools::SimulateCommandOptions simulate_options;
  graphslam::tools::AddSimulateCommand(&app, &simulate_options, &exit_code);
  graphslam::tools::EvaluateCommandOptions evaluate_options;
  graphslam::tools::AddEvaluateCommand(&app, &evaluate_options, &exit_code);
  graphslam::tools::IngestCommandOptions ingest_options;
  graphslam::tools::AddIngestCommand(&app, &ingest_options, &exit_code);
  graphslam::tools::MapCommandOptions map_options;
  graphslam::tools::AddMapCommand(&app, &map_options, &exit_code);
  graphslam::tools::RunCommandOptions run_options;
  graphslam::tools::AddRunCommand(&app, &run_options, &exit_code);
  graphslam::tools::BenchmarkCommandOptions benchmark_options;
  graphslam::tools::AddBenchmarkCommand(&app, &benchmark_options, &exit_code);
  if (const std::string line = graphslam::tools::UnknownSubcommandLine(app, argc, argv);
      !line.empty()) {
    std::fprintf(stderr, "%s\n", line.c_str());
    return graphslam::tools::kExitUsage;
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    // --help and --version end the parse with exit code 0; CLI11 prints them.
    if (error.get_exit_code() == 0) return app.exit(error);
    std::fprintf(stderr, "%s\n",
                 graphslam::tools::UsageErrorLine(app, argc, argv, error).c_str());
    return graphslam::tools::kExitUsage;
  }
  return exit_code;
}
