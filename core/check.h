// GS_CHECK (always on) and GS_DCHECK (debug builds only): invariants of our own
// code. A failed check is a bug in graphslam, never bad input; bad input is a
// Status. On failure the condition, file and line go to stderr and the process
// aborts. Bare assert() is not used in this project.
#pragma once

namespace graphslam::internal {
[[noreturn]] void CheckFailed(const char* condition, const char* file, int line);
}  // namespace graphslam::internal

#define GS_CHECK(condition)                                               \
  do {                                                                    \
    if (!(condition)) [[unlikely]]                                        \
      ::graphslam::internal::CheckFailed(#condition, __FILE__, __LINE__); \
  } while (0)

#ifdef NDEBUG
#define GS_DCHECK(condition) \
  do {                       \
    (void)sizeof(condition); \
  } while (0)
#else
#define GS_DCHECK(condition) GS_CHECK(condition)
#endif
