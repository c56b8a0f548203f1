#include "tools/progress_display.h"

#include <unistd.h>

#include <cstdio>

#include "core/logging.h"

namespace graphslam::tools {

ProgressDisplay::ProgressDisplay(bool enabled, double min_log_interval)
    : enabled_(enabled), terminal_(isatty(STDERR_FILENO) != 0), min_log_interval_(min_log_interval) {}

ProgressDisplay::~ProgressDisplay() { Finish(); }

void ProgressDisplay::Update(std::string_view stage, int64_t done, int64_t total) {
  if (!enabled_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  const Clock::time_point now = Clock::now();
  if (stage != stage_) {
    // The throttle is not reset: passes change stage several times per
    // iteration and would otherwise print a line each.
    stage_ = std::string(stage);
    auto found = stage_starts_.find(stage);
    if (found == stage_starts_.end()) found = stage_starts_.emplace(stage_, now).first;
    stage_start_ = found->second;
  }
  const double elapsed = std::chrono::duration<double>(now - stage_start_).count();
  const double since_output = std::chrono::duration<double>(now - last_output_).count();
  const bool complete = total > 0 && done >= total;
  const double rate = elapsed > 0 ? static_cast<double>(done) / elapsed : 0.0;
  const double eta = (rate > 0 && total > done) ? static_cast<double>(total - done) / rate : 0.0;
  if (terminal_) {
    if (since_output < 0.1 && !complete) return;
    std::fprintf(stderr, "\r[%s] %lld/%lld  %.1f/s  ETA %.0fs   ", stage_.c_str(),
                 static_cast<long long>(done), static_cast<long long>(total), rate, eta);
    line_open_ = true;
    if (complete) {
      std::fprintf(stderr, "\n");
      line_open_ = false;
    }
    std::fflush(stderr);
  } else {
    // At most one line per stage per interval; single-chunk passes are noise.
    if (total <= 1 && stage_ != "optimize") return;
    Clock::time_point& last = stage_outputs_[stage_];
    if (std::chrono::duration<double>(now - last).count() < min_log_interval_) return;
    last = now;
    GS_LOG(INFO, "progress stage=%s done=%lld total=%lld rate=%.2f/s eta=%.0fs", stage_.c_str(),
           static_cast<long long>(done), static_cast<long long>(total), rate, eta);
  }
  last_output_ = now;
}

void ProgressDisplay::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (line_open_) {
    std::fprintf(stderr, "\n");
    line_open_ = false;
  }
}

ProgressCallback ProgressDisplay::AsCallback() {
  return [this](std::string_view stage, int64_t done, int64_t total) { Update(stage, done, total); };
}

}  // namespace graphslam::tools
