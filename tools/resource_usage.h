// Peak resident set size of this process, from getrusage (Linux reports
// ru_maxrss in KiB), and the CPU seconds it has used (user + system, all
// threads): on a shared machine the cost of a run, where wall time also
// counts the waits for a core.
#pragma once

#include <sys/resource.h>

#include <cstdint>

namespace graphslam::tools {

inline int64_t PeakRssBytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<int64_t>(usage.ru_maxrss) * 1024;
}

inline double ProcessCpuSeconds() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0.0;
  return static_cast<double>(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

}  // namespace graphslam::tools
