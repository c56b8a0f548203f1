// RunChildProcess: runs this very binary (/proc/self/exe) with `args` as a
// child process and measures what it cost, as `/usr/bin/time -v` would:
// wall seconds (steady clock), CPU seconds (user + system of the child and
// its threads) and peak resident set size, from wait4's rusage. A benchmark
// runs each step as its own process so that every step's peak memory is its
// own, and a failing step is an exit code, not a crash of the sweep.
//
// The child's stdout and stderr go to `log_path` (appended); its exit code is
// returned in the result (128 + N for a signal N).
//
// THREAD SAFETY: reentrant. ALLOCATION: the argument vector.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/status.h"

namespace graphslam::tools::benchmark {

struct ChildCost {
  int exit_code = -1;
  double wall_seconds = 0;
  double cpu_seconds = 0;
  int64_t peak_rss_bytes = 0;
};

StatusOr<ChildCost> RunChildProcess(const std::vector<std::string>& args,
                                    const std::string& log_path);

}  // namespace graphslam::tools::benchmark
