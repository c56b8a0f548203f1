// Progress reporting from libraries to the tool that owns the terminal.
//
// Libraries never print; long work calls a ProgressCallback with the stage
// name and done/total counts (total may be 0 when unknown). The tool turns the
// calls into a terminal progress line (rate, ETA) or plain log lines.
//
// THREAD SAFETY: a callback may be invoked from any thread; implementations
// must be thread-safe.
#pragma once

#include <cstdint>
#include <functional>
#include <string_view>

namespace graphslam {

using ProgressCallback =
    std::function<void(std::string_view stage, int64_t done, int64_t total)>;

}  // namespace graphslam
