// The figures of report.html, each an inline SVG (svg_figure.h):
//   - MapFigure: the top-down map picture (map_image.h) with the run colours;
//   - TrajectoryFigure: every run's optimized path (its colour), the
//     landmarks (grey crosses) and GPS fixes (amber dots) below, and ground
//     truth ON TOP (black, dashed; mapped into the estimate's frame by the
//     run's ATE alignment), so both stay visible where they coincide;
//   - ErrorOverTimeFigure: a run's absolute position error per pose over time;
//   - ResidualHistogram: the per-constraint chi2 of one constraint type as a
//     density histogram with the chi2 density of its degrees of freedom over
//     it (constraint_residuals.h), cut at the 99th percentile or at the chi2
//     99.9 % quantile, whichever is larger (the rest counted in the caption);
//   - ConvergenceFigure / DampingFigure: chi2 (log) per Levenberg-Marquardt
//     iteration per component, rejected steps as red crosses at the chi2
//     they would have led to; the damping lambda (log) per iteration,
//     rejected iterations marked the same way. From report.json's component
//     `history` (iteration, chi2, lambda, accepted, candidate_chi2).
//
// THREAD SAFETY: pure functions. ALLOCATION: O(points).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "tools/job/constraint_residuals.h"
#include "tools/job/map_image.h"
#include "tools/job/report_inputs.h"
#include "tools/trajectory_statistics.h"

namespace graphslam::tools::job {

std::string MapFigure(const MapRaster& raster, const std::vector<ReportRun>& runs);

// `alignment[r]`: run r's estimate -> ground truth transform, if it has one.
std::string TrajectoryFigure(const ReportInputs& inputs,
                             const std::vector<std::optional<Eigen::Isometry2d>>& alignment);

std::string ErrorOverTimeFigure(const std::string& run, const std::string& colour,
                                const AbsoluteErrors& errors);

// `*beyond` receives the number of values right of the plotted range.
std::string ResidualHistogram(const ConstraintChi2& residuals, int64_t* beyond);

std::string ConvergenceFigure(const nlohmann::json& components);
std::string DampingFigure(const nlohmann::json& components);

// The chi2 quantile p (0.95, 0.999) for k = 1..6 degrees of freedom (table
// values); NaN otherwise.
double Chi2Quantile(double p, int k);

}  // namespace graphslam::tools::job
