// The scaling benchmark's results (tools/benchmark/scaling_sweep.h), written
// into OUT after every size, each file atomically:
//
//   scaling.csv    one row per size (the columns of ScalingRow)
//   scaling.html   one self-contained page: the proportion, the table, and
//                  one log-log plot per quantity against features (end-to-end
//                  seconds, seconds per iteration, peak RSS, store bytes),
//                  each with the fitted power-law exponent k of y ~ c·N^k
//                  (tools/benchmark/power_law_fit.h): k near 1 is linear.
//                  The plots are inline SVG (tools/job/svg_figure.h).
//
// THREAD SAFETY: reentrant. ALLOCATION: O(rows).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/status.h"
#include "tools/benchmark/power_law_fit.h"
#include "tools/benchmark/scaling_sweep.h"

namespace graphslam::tools::benchmark {

// The quantities plotted, with their fits (for the page and for tests).
struct ScalingQuantity {
  std::string name;  // "end-to-end seconds", ...
  std::string unit;  // "s", "MiB"
  std::vector<double> features;
  std::vector<double> values;
  PowerLaw fit;
};
std::vector<ScalingQuantity> ScalingQuantities(const std::vector<ScalingRow>& rows);

std::string ScalingCsv(const std::vector<ScalingRow>& rows);

[[nodiscard]] Status WriteScalingResults(const std::string& output,
                                         const std::vector<ScalingRow>& rows,
                                         const nlohmann::json& proportion);

}  // namespace graphslam::tools::benchmark
