// `graphslam run JOB.yaml [--resume]`: a batch job over one or more runs
// (tools/job/job_runner.h, docs/jobs.md).
#pragma once

#include <string>

#include "tools/cli_fwd.h"

namespace graphslam::tools {

struct RunCommandOptions {
  std::string job;
  std::string output;  // -o: overrides the job file's output folder
  bool resume = false;
  bool quiet = false;
  int verbosity = 0;
};

void AddRunCommand(CLI::App* app, RunCommandOptions* options, int* exit_code);

// Runs the job; returns the process exit code (tools/exit_codes.h).
int RunRunCommand(const RunCommandOptions& options);

}  // namespace graphslam::tools
