// The logging facade: GS_LOG(INFO|WARNING|ERROR, format, ...) and
// GS_VLOG(level, format, ...), printf-checked, always compiled.
//
// Libraries never print to stdout; they log through this facade, whose sink is
// spdlog (stderr by default). The command-line tool decides the verbosity and
// may add a file sink. GS_VLOG(n) messages show when the verbosity is >= n.
//
// THREAD SAFETY: all functions may be called from any thread.
#pragma once

#include <string>

namespace graphslam {

enum class LogSeverity { kINFO, kWARNING, kERROR };

void LogMessage(LogSeverity severity, const char* file, int line, const char* format, ...)
    __attribute__((__format__(__printf__, 4, 5)));

// Verbosity for GS_VLOG; 0 by default.
void SetLogVerbosity(int level);
int LogVerbosity();
// Sends log lines also to `path` (appending). Returns false if it cannot be opened.
bool AddLogFile(const std::string& path);
// Suppresses INFO lines on stderr (warnings and errors still show).
void SetQuietLogging(bool quiet);

}  // namespace graphslam

#define GS_LOG(severity, ...) \
  ::graphslam::LogMessage(::graphslam::LogSeverity::k##severity, __FILE__, __LINE__, __VA_ARGS__)
#define GS_VLOG(level, ...)                                                              \
  do {                                                                                   \
    if (::graphslam::LogVerbosity() >= (level))                                          \
      ::graphslam::LogMessage(::graphslam::LogSeverity::kINFO, __FILE__, __LINE__, __VA_ARGS__); \
  } while (0)
