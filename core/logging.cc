#include "core/logging.h"

#include <spdlog/sinks/basic_file_sink.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cstdarg>
#include <cstdio>
#include <memory>
#include <mutex>
#include <vector>

namespace graphslam {
namespace {

// The facade's single logger. It is process-wide by nature (like stderr); it is
// created on first use and holds no algorithm state.
struct LogState {
  std::mutex mutex;
  std::shared_ptr<spdlog::logger> logger;
  std::atomic<int> verbosity{0};
  std::atomic<bool> quiet{false};
};

LogState& State() {
  static LogState* state = [] {
    auto* s = new LogState;
    auto sink = std::make_shared<spdlog::sinks::stderr_sink_mt>();
    s->logger = std::make_shared<spdlog::logger>("graphslam", sink);
    s->logger->set_pattern("%Y-%m-%dT%H:%M:%S.%e %L %v");
    s->logger->set_level(spdlog::level::info);
    return s;
  }();
  return *state;
}

const char* BaseName(const char* path) {
  const char* base = path;
  for (const char* p = path; *p; ++p)
    if (*p == '/') base = p + 1;
  return base;
}

}  // namespace

void LogMessage(LogSeverity severity, const char* file, int line, const char* format, ...) {
  char buffer[2048];
  va_list args;
  va_start(args, format);
  std::vsnprintf(buffer, sizeof(buffer), format, args);
  va_end(args);
  LogState& state = State();
  spdlog::level::level_enum level = spdlog::level::info;
  if (severity == LogSeverity::kWARNING) level = spdlog::level::warn;
  if (severity == LogSeverity::kERROR) level = spdlog::level::err;
  // log_msg keeps a view of its text: the string must outlive the sink calls.
  const std::string text = fmt::format("{}:{}] {}", BaseName(file), line, buffer);
  std::lock_guard<std::mutex> lock(state.mutex);
  for (auto& sink : state.logger->sinks()) {
    // The first sink is stderr; quiet mode hides its INFO lines only.
    bool is_stderr = sink == state.logger->sinks().front();
    if (is_stderr && state.quiet && level == spdlog::level::info) continue;
    spdlog::details::log_msg message(spdlog::source_loc{}, "graphslam", level, text);
    sink->log(message);
  }
}

void SetLogVerbosity(int level) { State().verbosity = level; }
int LogVerbosity() { return State().verbosity; }
void SetQuietLogging(bool quiet) { State().quiet = quiet; }

bool AddLogFile(const std::string& path) {
  LogState& state = State();
  try {
    auto sink = std::make_shared<spdlog::sinks::basic_file_sink_mt>(path, false);
    sink->set_pattern("%Y-%m-%dT%H:%M:%S.%e %L %v");
    std::lock_guard<std::mutex> lock(state.mutex);
    state.logger->sinks().push_back(sink);
    return true;
  } catch (const spdlog::spdlog_ex&) {
    return false;
  }
}

}  // namespace graphslam
