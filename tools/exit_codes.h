// Exit codes of the graphslam command line (docs/cli.md).
#pragma once

#include "core/status.h"

namespace graphslam::tools {

inline constexpr int kExitOk = 0;
inline constexpr int kExitUsage = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitIOError = 3;
// `solve` stopped at --max-iterations; the outputs ARE written.
inline constexpr int kExitNotConverged = 4;
// A numerical failure (a non-finite chi2, a factorization that failed):
// nothing was written. Not 4, whose promise is "outputs written".
inline constexpr int kExitNumericalFailure = 5;

// Maps a Status to the exit code a script can act on.
inline int ExitCodeFor(const Status& status) {
  if (status.ok()) return kExitOk;
  if (status.IsIOError()) return kExitIOError;
  if (status.IsNumerical()) return kExitNumericalFailure;
  return kExitBadInput;  // Corruption, InvalidArgument, NotFound, NotSupported
}

}  // namespace graphslam::tools
