#include "tools/job/report_figures.h"

#include <algorithm>
#include <cmath>

#include "tools/job/svg_figure.h"

namespace graphslam::tools::job {
namespace {

using Style = SvgSeries::Style;
using nlohmann::json;

constexpr const char* kTruthColour = "#000000";
constexpr const char* kFeatureColour = "#9a9a9a";
constexpr const char* kGpsColour = "#e6ab02";
constexpr const char* kRejectedColour = "#d62728";

// "component 0"; the components table lists its runs.
std::string ComponentName(const json& c) {
  return "component " + std::to_string(c.value("component", 0));
}

double Number(const json& j, const char* key) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : NAN;
}

}  // namespace

std::string MapFigure(const MapRaster& raster, const std::vector<ReportRun>& runs) {
  SvgFigure f;
  f.title = "Map from above (" + std::to_string(raster.points) + " points of the point cloud)";
  f.x_label = "x [m]";
  f.y_label = "y [m]";
  f.width = 900;
  f.height = 640;
  f.equal_axes = true;
  f.image = SvgImage{raster.png, raster.x0, raster.x1, raster.y0, raster.y1};
  for (int r : raster.runs)
    f.legend_only.emplace_back(
        r >= 0 && static_cast<size_t>(r) < runs.size() ? runs[static_cast<size_t>(r)].name
                                                       : "run " + std::to_string(r),
        SeriesColour(static_cast<size_t>(std::max(r, 0))));
  return RenderSvg(f);
}

std::string TrajectoryFigure(const ReportInputs& inputs,
                             const std::vector<std::optional<Eigen::Isometry2d>>& alignment) {
  SvgFigure f;
  f.title = "Trajectories over the landmark map";
  f.x_label = "x [m]";
  f.y_label = "y [m]";
  f.height = 640;
  f.equal_axes = true;
  if (!inputs.features.empty()) {
    SvgSeries features{"landmarks", kFeatureColour, Style::kCrosses, 2.5, false, {}, {}};
    for (const core::Point2& p : inputs.features) features.x.push_back(p.x()), features.y.push_back(p.y());
    f.series.push_back(std::move(features));
  }
  if (!inputs.gps.empty()) {
    SvgSeries gps{"GPS fixes", kGpsColour, Style::kPoints, 1.6, false, {}, {}};
    for (const core::Point2& p : inputs.gps) gps.x.push_back(p.x()), gps.y.push_back(p.y());
    f.series.push_back(std::move(gps));
  }
  for (size_t r = 0; r < inputs.runs.size(); ++r) {
    SvgSeries s{inputs.runs[r].name + " (estimate)", SeriesColour(r), Style::kLine, 2.0, false, {}, {}};
    for (const StampedPose2& p : inputs.runs[r].estimated)
      s.x.push_back(p.pose.x()), s.y.push_back(p.pose.y());
    f.series.push_back(std::move(s));
  }
  bool first_truth = true;
  for (size_t r = 0; r < inputs.runs.size(); ++r) {
    if (r >= alignment.size() || !alignment[r] || inputs.runs[r].ground_truth.empty()) continue;
    const Eigen::Isometry2d inverse = alignment[r]->inverse();
    SvgSeries s{first_truth ? "ground truth" : "", kTruthColour, Style::kLine, 1.0, true, {}, {}};
    for (const StampedPose2& p : inputs.runs[r].ground_truth) {
      const Eigen::Vector2d q = inverse * p.pose.head<2>();
      s.x.push_back(q.x()), s.y.push_back(q.y());
    }
    f.series.push_back(std::move(s));
    first_truth = false;
  }
  return RenderSvg(f);
}

std::string ErrorOverTimeFigure(const std::string& run, const std::string& colour,
                                const AbsoluteErrors& errors) {
  SvgFigure f;
  f.title = "Position error over time: " + run;
  f.x_label = "time [s]";
  f.y_label = "absolute position error [m]";
  f.width = 700;
  f.height = 340;
  f.y_min = 0.0;
  SvgSeries s{"", colour, Style::kLine, 1.5, false, errors.stamps, errors.position};
  f.series.push_back(std::move(s));
  if (errors.statistics.count > 0) {
    const double t0 = errors.stamps.front(), t1 = errors.stamps.back();
    f.series.push_back({"RMSE", "#555555", Style::kLine, 1.0, true, {t0, t1},
                        {errors.statistics.rmse, errors.statistics.rmse}});
  }
  return RenderSvg(f);
}

double Chi2Quantile(double p, int k) {
  static const double k95[] = {3.841, 5.991, 7.815, 9.488, 11.070, 12.592};
  static const double k999[] = {10.828, 13.816, 16.266, 18.467, 20.515, 22.458};
  if (k < 1 || k > 6) return NAN;
  if (p == 0.95) return k95[k - 1];
  if (p == 0.999) return k999[k - 1];
  return NAN;
}

std::string ResidualHistogram(const ConstraintChi2& residuals, int64_t* beyond) {
  std::vector<double> sorted = residuals.chi2;
  std::sort(sorted.begin(), sorted.end());
  double top = sorted.empty() ? 1.0 : sorted[static_cast<size_t>(0.99 * (sorted.size() - 1))];
  const double q = Chi2Quantile(0.999, residuals.dof);
  if (std::isfinite(q)) top = std::max(top, q);
  top = std::max(top, 1e-9);
  constexpr int kBins = 40;
  const double width = top / kBins;
  std::vector<double> counts(kBins, 0.0);
  *beyond = 0;
  for (double s : sorted) {
    if (s > top) {
      ++*beyond;
      continue;
    }
    ++counts[static_cast<size_t>(std::min(kBins - 1, static_cast<int>(s / width)))];
  }
  SvgFigure f;
  f.title = residuals.type + ": per-constraint chi2";
  f.x_label = "chi2 = e^T W e";
  f.y_label = "density";
  f.width = 640;
  f.height = 380;
  f.y_min = 0.0;
  f.x_min = 0.0;
  f.x_max = top;
  const double n = std::max<double>(1.0, static_cast<double>(sorted.size()));
  SvgBars bars{"constraints (" + std::to_string(sorted.size()) + ")", "#1f77b4", {}, {}, {}};
  for (int b = 0; b < kBins; ++b) {
    bars.left.push_back(b * width);
    bars.right.push_back((b + 1) * width);
    bars.height.push_back(counts[static_cast<size_t>(b)] / (n * width));
  }
  f.bars.push_back(std::move(bars));
  SvgSeries curve{"chi2, " + std::to_string(residuals.dof) + " dof", "#d62728", Style::kLine, 2.0,
                  false, {}, {}};
  for (int i = 0; i <= 200; ++i) {
    const double s = std::max(top * i / 200.0, top * 1e-4);
    curve.x.push_back(s);
    curve.y.push_back(Chi2Density(s, residuals.dof));
  }
  // Keep the y range on the histogram when the density has a pole at 0.
  double highest = 0;
  for (double h : f.bars[0].height) highest = std::max(highest, h);
  double density_top = 0;
  for (double y : curve.y) density_top = std::max(density_top, std::isfinite(y) ? y : 0.0);
  f.y_max = 1.05 * std::max(highest, std::min(density_top, 3 * std::max(highest, 1e-12)));
  f.series.push_back(std::move(curve));
  return RenderSvg(f);
}

namespace {

// A log-scale quantity per iteration.
SvgFigure IterationFigure(const std::string& title, const std::string& y_label) {
  SvgFigure f;
  f.title = title;
  f.x_label = "iteration";
  f.y_label = y_label;
  f.width = 720;
  f.height = 400;
  f.log_y = true;
  return f;
}

}  // namespace

std::string ConvergenceFigure(const json& components) {
  SvgFigure f = IterationFigure("Convergence: chi2 per iteration", "chi2 (log scale)");
  SvgSeries rejected{"rejected step (chi2 it led to)", kRejectedColour, Style::kCrosses, 4.0, false,
                     {}, {}};
  size_t i = 0;
  for (const json& c : components) {
    SvgSeries line{ComponentName(c), SeriesColour(i), Style::kLine, 2.0, false, {}, {}};
    SvgSeries dots{"", SeriesColour(i), Style::kPoints, 2.5, false, {}, {}};
    line.x.push_back(0);
    line.y.push_back(Number(c, "initial_chi2"));
    for (const json& h : c.value("history", json::array())) {
      const double it = Number(h, "iteration"), chi2 = Number(h, "chi2");
      line.x.push_back(it);
      line.y.push_back(chi2);
      if (h.value("accepted", true)) {
        dots.x.push_back(it), dots.y.push_back(chi2);
      } else {
        const double candidate = Number(h, "candidate_chi2");
        rejected.x.push_back(it);
        rejected.y.push_back(std::isfinite(candidate) ? std::min(candidate, 1e3 * chi2) : chi2);
      }
    }
    dots.x.insert(dots.x.begin(), 0.0);
    dots.y.insert(dots.y.begin(), line.y.front());
    f.series.push_back(std::move(line));
    f.series.push_back(std::move(dots));
    ++i;
  }
  if (!rejected.x.empty()) f.series.push_back(std::move(rejected));
  return RenderSvg(f);
}

std::string DampingFigure(const json& components) {
  SvgFigure f = IterationFigure("Damping lambda per iteration", "lambda (log scale)");
  SvgSeries rejected{"rejected step", kRejectedColour, Style::kCrosses, 4.0, false, {}, {}};
  size_t i = 0;
  for (const json& c : components) {
    SvgSeries line{ComponentName(c), SeriesColour(i), Style::kLine, 2.0, false, {}, {}};
    for (const json& h : c.value("history", json::array())) {
      const double lambda = Number(h, "lambda");
      if (!std::isfinite(lambda)) continue;
      line.x.push_back(Number(h, "iteration"));
      line.y.push_back(lambda);
      if (!h.value("accepted", true)) rejected.x.push_back(line.x.back()), rejected.y.push_back(lambda);
    }
    f.series.push_back(std::move(line));
    ++i;
  }
  if (!rejected.x.empty()) f.series.push_back(std::move(rejected));
  return RenderSvg(f);
}

}  // namespace graphslam::tools::job
