// Report plots drawn with PLplot (Debian's libplplot, pngcairo driver) into
// PNG files, returned as bytes for embedding (report_html.h).
//
//   - trajectories: every run's optimized path (one colour per run), its GPS
//     fixes (dots) and ground truth (thin grey), over the map's features
//     (crosses); equal axis scales.
//   - convergence: chi2 per Levenberg-Marquardt iteration, log10 scale, one
//     curve per solved component.
//   - stages: wall time per stage (bars) with the peak resident memory at
//     the end of each stage written above its bar.
//
// PLplot writes to a file; `scratch` names the temporary PNG (removed after
// reading). Each plot uses its own plstream, so nothing is shared.
//
// THREAD SAFETY: PLplot keeps global stream tables: call from one thread.
// ALLOCATION: O(points) plus the image.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"

namespace graphslam::tools::job {

struct XySeries {
  std::string name;
  std::vector<double> x;
  std::vector<double> y;
};

struct TrajectoryPlot {
  std::vector<XySeries> estimated;     // one per run
  std::vector<XySeries> ground_truth;  // aligned to the estimate's frame; may be empty
  XySeries gps;                        // all fixes
  XySeries features;                   // the map
  std::string title;
};

StatusOr<std::string> PlotTrajectories(const TrajectoryPlot& plot, const std::string& scratch);

// `curves[i].x` are iteration numbers and `.y` chi2 values (> 0).
StatusOr<std::string> PlotConvergence(const std::vector<XySeries>& curves,
                                      const std::string& scratch);

struct StageBar {
  std::string stage;
  double seconds = 0;
  double peak_rss_mib = 0;
};
StatusOr<std::string> PlotStages(const std::vector<StageBar>& stages, const std::string& scratch);

}  // namespace graphslam::tools::job
