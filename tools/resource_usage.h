// Peak resident set size of this process, from getrusage (Linux reports
// ru_maxrss in KiB).
#pragma once

#include <sys/resource.h>

#include <cstdint>

namespace graphslam::tools {

inline int64_t PeakRssBytes() {
  rusage usage{};
  if (getrusage(RUSAGE_SELF, &usage) != 0) return 0;
  return static_cast<int64_t>(usage.ru_maxrss) * 1024;
}

}  // namespace graphslam::tools
