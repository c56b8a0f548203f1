// The graphslam command line: one binary, subcommands (docs/cli.md).
#include <CLI/CLI.hpp>

#include <cstdio>

#include "tools/evaluate_command.h"
#include "tools/exit_codes.h"
#include "tools/ingest_command.h"
#include "tools/map_command.h"
#include "tools/run_command.h"
#include "tools/simulate_command.h"
#include "tools/solve_command.h"

int main(int argc, char** argv) {
  CLI::App app{"graphslam: offline GraphSLAM map builder (Thrun & Montemerlo)"};
  app.require_subcommand(1);
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
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);
    return code == 0 ? graphslam::tools::kExitOk : graphslam::tools::kExitUsage;
  }
  return exit_code;
}
