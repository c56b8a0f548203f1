// report.html: ONE self-contained page (no external file, script or font;
// figures are inline SVG, rasters PNG data URIs in base64, RFC 4648 alphabet
// with '=' padding), built from report.json and ReportInputs
// (report_inputs.h). Sections, each <section id=...>:
//   summary      runs, poses, landmarks, total time, peak memory, ATE
//   map          the map from above, coloured by run (map_image.h)
//   trajectories estimates, landmarks, GPS, ground truth on top
//   accuracy     per run: ATE and RPE (1 m, 10 m) tables, error over time
//                (trajectory_statistics.h, each run aligned on its own as
//                report.json's position_rmse_m)
//   residuals    per-constraint chi2 histogram by type with its chi2 density
//   convergence  chi2 and damping per iteration, rejected steps marked
//   stages       wall time and peak memory per stage
// plus runs, components, GPS comparison, robot sightings and map tables and
// report.json itself (folded). Numbers carry units and 3 significant digits;
// a numeric cell keeps its full value in data-value. Tables scroll sideways
// inside their box, figures scale with the page: readable from 1024 px up.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(report + inputs + images).
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "core/status.h"
#include "tools/job/report_inputs.h"

namespace graphslam::tools::job {

std::string Base64(const std::string& bytes);

// Errors: a map .pcd that cannot be read (named).
StatusOr<std::string> RenderReportHtml(const nlohmann::json& report, const ReportInputs& inputs);

// Human units: "0.0123", "1.23", "123", "1 230" (3 significant digits,
// thin grouping of thousands, no exponent below 1e9); "NaN" -> "–".
std::string Significant(double value);
// "0.52 s", "12.3 s", "2 min 05 s", "1 h 02 min".
std::string HumanSeconds(double seconds);
// "512 KiB", "42.0 MiB", "1.50 GiB".
std::string HumanBytes(int64_t bytes);

}  // namespace graphslam::tools::job
