#include "core/check.h"

#include <cstdio>
#include <cstdlib>

namespace graphslam::internal {

void CheckFailed(const char* condition, const char* file, int line) {
  std::fprintf(stderr, "graphslam: check failed at %s:%d: %s\n", file, line, condition);
  std::fflush(stderr);
  std::abort();
}

}  // namespace graphslam::internal
