// ProgressDisplay: turns library progress callbacks into what a person sees.
//
// On a terminal (stderr is a TTY) it redraws one line:
//   [optimize] 12/100  3.4/s  ETA 26s
// Otherwise (batch jobs, CI, log files) it writes a plain log line at most once
// per `min_log_interval` seconds per stage, plus one when a stage completes.
//
// THREAD SAFETY: Update() may be called from any thread (guarded by a mutex).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <string_view>

#include "core/progress.h"

namespace graphslam::tools {

class ProgressDisplay {
 public:
  explicit ProgressDisplay(bool enabled, double min_log_interval = 5.0);
  ~ProgressDisplay();

  void Update(std::string_view stage, int64_t done, int64_t total);
  // Ends the current terminal line, if any.
  void Finish();
  ProgressCallback AsCallback();

 private:
  using Clock = std::chrono::steady_clock;
  std::mutex mutex_;
  bool enabled_;
  bool terminal_;
  double min_log_interval_;
  std::string stage_;
  Clock::time_point stage_start_;
  // When each stage was first seen, so that rates span interleaved passes.
  std::map<std::string, Clock::time_point, std::less<>> stage_starts_;
  std::map<std::string, Clock::time_point, std::less<>> stage_outputs_;
  Clock::time_point last_output_;
  bool line_open_ = false;
};

}  // namespace graphslam::tools
