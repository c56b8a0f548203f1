#include "tools/progress_display.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>

#include "core/graphslam_solver.h"
#include "core/logging.h"

namespace graphslam::tools {
namespace {

// Erases the terminal line the cursor is on (carriage return + ANSI EL).
constexpr const char* kClearLine = "\r\033[K";

}  // namespace

std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  char text[32];
  const long long whole = std::llround(seconds);
  if (whole < 60) {
    std::snprintf(text, sizeof(text), "%llds", whole);
  } else if (whole < 3600) {
    std::snprintf(text, sizeof(text), "%lldm%02llds", whole / 60, whole % 60);
  } else {
    std::snprintf(text, sizeof(text), "%lldh%02lldm", whole / 3600, (whole % 3600) / 60);
  }
  return text;
}

ProgressDisplay::ProgressDisplay(bool enabled, double min_log_interval)
    : ProgressDisplay(enabled, min_log_interval, isatty(STDERR_FILENO) != 0, &Clock::now) {}

ProgressDisplay::ProgressDisplay(bool enabled, double min_log_interval, bool terminal,
                                 NowFunction now)
    : enabled_(enabled),
      terminal_(terminal),
      min_log_interval_(min_log_interval),
      now_(std::move(now)) {}

ProgressDisplay::~ProgressDisplay() { Finish(); }

void ProgressDisplay::SetContext(std::string context) {
  std::lock_guard<std::mutex> lock(mutex_);
  context_ = std::move(context);
  table_header_printed_ = false;
  table_seconds_ = 0.0;
}

std::string ProgressDisplay::Label(std::string_view stage) const {
  if (context_.empty()) return std::string(stage);
  std::string label = context_;
  label.append(": ").append(stage);
  return label;
}

void ProgressDisplay::Update(std::string_view stage, int64_t done, int64_t total) {
  if (!enabled_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  const Clock::time_point now = now_();
  auto found = passes_.find(stage);
  if (found == passes_.end()) {
    found = passes_.emplace(std::string(stage), Pass{now, done, done, std::nullopt}).first;
  } else if (done < found->second.last_done) {
    // A new pass of a stage seen before (the next iteration's reduce).
    found->second.start = now;
    found->second.start_done = done;
  }
  Pass& pass = found->second;
  pass.last_done = done;
  const double elapsed = std::chrono::duration<double>(now - pass.start).count();
  const bool complete = total > 0 && done >= total;
  const bool rate_known = elapsed > 0 && done > pass.start_done;
  const double rate = rate_known ? static_cast<double>(done - pass.start_done) / elapsed : 0.0;
  const bool eta_known = rate_known && total > done;
  const double eta = eta_known ? static_cast<double>(total - done) / rate : 0.0;

  // A single-chunk pass is over as soon as it is shown: noise.
  if (total == 1) return;
  std::string counts = std::to_string(done);
  if (total > 0) counts.append("/").append(std::to_string(total));
  if (terminal_) {
    if (complete) {  // the line is transient: what follows takes its place
      CloseLineLocked();
      std::fflush(stderr);
      return;
    }
    if (last_redraw_ && std::chrono::duration<double>(now - *last_redraw_).count() < 0.1) return;
    last_redraw_ = now;
    std::string line = "[";
    line.append(Label(stage)).append("] ").append(counts);
    char numbers[64];
    if (rate_known) {
      std::snprintf(numbers, sizeof(numbers), "  %.3g/s", rate);
      line += numbers;
    }
    if (eta_known) line.append("  ETA ").append(FormatDuration(eta));
    std::fprintf(stderr, "%s%s", kClearLine, line.c_str());
    line_open_ = true;
    std::fflush(stderr);
    return;
  }
  if (!complete && pass.last_log &&
      std::chrono::duration<double>(now - *pass.last_log).count() < min_log_interval_)
    return;
  pass.last_log = now;
  std::string line = "progress stage=\"";
  line.append(Label(stage)).append("\" done=").append(std::to_string(done));
  if (total > 0) line.append(" total=").append(std::to_string(total));
  char numbers[96];
  if (rate_known) {
    std::snprintf(numbers, sizeof(numbers), " rate=%.3g/s", rate);
    line += numbers;
  }
  if (eta_known) line.append(" eta=").append(FormatDuration(eta));
  GS_LOG(INFO, "%s", line.c_str());
}

void ProgressDisplay::Iteration(const core::IterationSummary& it) {
  if (!enabled_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  table_seconds_ += it.seconds;
  const double change = it.start_chi2 - it.candidate_chi2;
  const char* verdict = it.accepted ? "" : "  rejected";
  if (!terminal_) {
    GS_LOG(INFO,
           "iteration %s%d chi2=%.9g chi2_change=%.4g gradient=%.3g step=%.3g lambda=%.3g "
           "rho=%.3g linear_iterations=%d seconds=%.3f total_seconds=%.3f%s",
           context_.empty() ? "" : (context_ + " ").c_str(), it.iteration, it.chi2, change,
           it.gradient_max_norm, it.step_norm, it.lambda, it.relative_decrease,
           it.linear_iterations, it.seconds, table_seconds_, it.accepted ? "" : " rejected");
    return;
  }
  CloseLineLocked();
  if (!table_header_printed_) {
    if (!context_.empty()) std::fprintf(stderr, "%s\n", context_.c_str());
    std::fprintf(stderr, "%4s %13s %13s %11s %10s %9s %7s %7s %8s %8s\n", "iter", "chi2",
                 "chi2_change", "|gradient|", "|step|", "lambda", "rho", "lin_it", "it_time",
                 "total");
    // Row 0: where this solve starts, as in Ceres' table.
    if (it.iteration == 1) std::fprintf(stderr, "%4d %13.6e\n", 0, it.start_chi2);
    table_header_printed_ = true;
  }
  std::fprintf(stderr, "%4d %13.6e %13.4e %11.3e %10.3e %9.2e %7.3f %7d %7.2fs %7.2fs%s\n",
               it.iteration, it.chi2, change, it.gradient_max_norm, it.step_norm, it.lambda,
               it.relative_decrease, it.linear_iterations, it.seconds, table_seconds_, verdict);
  std::fflush(stderr);
  // The next progress line is drawn at once, not after the redraw interval.
  last_redraw_.reset();
}

void ProgressDisplay::CloseLineLocked() {
  if (!line_open_) return;
  std::fprintf(stderr, "%s", kClearLine);
  line_open_ = false;
}

void ProgressDisplay::Finish() {
  std::lock_guard<std::mutex> lock(mutex_);
  CloseLineLocked();
  std::fflush(stderr);
}

ProgressCallback ProgressDisplay::AsCallback() {
  return [this](std::string_view stage, int64_t done, int64_t total) { Update(stage, done, total); };
}

std::function<void(const core::IterationSummary&)> ProgressDisplay::AsIterationCallback() {
  return [this](const core::IterationSummary& it) { Iteration(it); };
}

}  // namespace graphslam::tools
