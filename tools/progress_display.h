// ProgressDisplay: turns library progress and iteration callbacks into what a
// person sees.
//
// On a terminal (stderr is a TTY) it redraws one transient line, cleared
// before each redraw (a shorter line never leaves pieces of a longer one) and
// when its stage completes:
//   [campus_1 with GPS: reduce] 12/100  3.4/s  ETA 26s
// and prints the solver's iterations as a table in the manner of Ceres'
// minimizer output (one header per solve, row 0 the start, one row per
// iteration):
//   iter        chi2   chi2_change   |gradient|     |step|    lambda    rho  lin_it  it_time  total
//      0  5.3155e+03
//      1  5.5857e+02    4.7570e+03    5.124e+02  4.150e+01  1.00e-04  0.973       1    0.57s   0.57s
// Otherwise (batch jobs, CI, log files) it writes plain log lines: at most one
// per `min_log_interval` seconds per stage (the first one at once, and one
// when it completes), plus one per iteration. Rate and ETA are printed only
// once they are known. Single-chunk passes (total 1) are not shown.
//
// rate = (done - done at the start of this pass) / seconds since that start;
// a pass starts when a stage is first seen or its `done` goes backwards.
// ETA  = (total - done) / rate.
//
// The clock is injectable so that tests can start it anywhere (a machine
// booted a minute ago has a steady_clock near zero).
//
// THREAD SAFETY: every method may be called from any thread (one mutex).
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include "core/progress.h"

namespace graphslam::core {
struct IterationSummary;
}

namespace graphslam::tools {

class ProgressDisplay {
 public:
  using Clock = std::chrono::steady_clock;
  using NowFunction = std::function<Clock::time_point()>;

  // Writes to a terminal when stderr is one.
  explicit ProgressDisplay(bool enabled, double min_log_interval = 5.0);
  // For tests: the output kind and the clock are given.
  ProgressDisplay(bool enabled, double min_log_interval, bool terminal, NowFunction now);
  ~ProgressDisplay();

  // Names what runs now ("campus_1 with GPS"); shown before every stage and
  // starts a new iteration table. Empty: no name.
  void SetContext(std::string context);

  void Update(std::string_view stage, int64_t done, int64_t total);
  // One row of the iteration table.
  void Iteration(const core::IterationSummary& iteration);
  // Ends the current terminal line, if any.
  void Finish();

  ProgressCallback AsCallback();
  std::function<void(const core::IterationSummary&)> AsIterationCallback();

 private:
  struct Pass {
    Clock::time_point start;
    int64_t start_done = 0;
    int64_t last_done = 0;
    std::optional<Clock::time_point> last_log;  // plain output only
  };

  std::string Label(std::string_view stage) const;
  void CloseLineLocked();

  std::mutex mutex_;
  const bool enabled_;
  const bool terminal_;
  const double min_log_interval_;
  const NowFunction now_;
  std::string context_;
  std::map<std::string, Pass, std::less<>> passes_;
  std::optional<Clock::time_point> last_redraw_;  // terminal only
  bool line_open_ = false;
  bool table_header_printed_ = false;
  double table_seconds_ = 0.0;  // sum of the iterations' seconds in this table
};

// "26s", "3m05s", "2h01m": how long, for a person.
std::string FormatDuration(double seconds);

}  // namespace graphslam::tools
