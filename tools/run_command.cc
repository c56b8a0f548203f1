#include "tools/run_command.h"

#include <CLI/CLI.hpp>
#include <cstdio>

#include "tools/exit_codes.h"
#include "tools/job/job_runner.h"

namespace graphslam::tools {

void AddRunCommand(CLI::App* app, RunCommandOptions* options, int* exit_code) {
  CLI::App* run = app->add_subcommand(
      "run", "Run a batch job file (runs, stages, outputs, report; docs/jobs.md)");
  run->add_option("job", options->job, "job file (.yaml)")->required();
  run->add_option("-o,--output", options->output, "output folder (overrides the job file's)");
  run->add_flag("--resume", options->resume,
                "continue an interrupted job from its last completed stage or iteration");
  run->add_flag("-q,--quiet", options->quiet, "no progress on the terminal");
  run->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  run->callback([options, exit_code]() { *exit_code = RunRunCommand(*options); });
}

int RunRunCommand(const RunCommandOptions& options) {
  job::RunJobOptions run;
  run.job_path = options.job;
  run.output = options.output;
  run.resume = options.resume;
  run.quiet = options.quiet;
  run.verbosity = options.verbosity;
  const Status status = job::RunJob(run);
  if (!status.ok()) {
    std::fprintf(stderr, "graphslam run: %s\n", status.ToString().c_str());
    return ExitCodeFor(status);
  }
  return kExitOk;
}

}  // namespace graphslam::tools
