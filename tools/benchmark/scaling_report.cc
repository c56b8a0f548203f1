#include "tools/benchmark/scaling_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "storage/atomic_file.h"
#include "tools/job/svg_figure.h"

namespace graphslam::tools::benchmark {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;

std::string Format(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

// A log-log figure of `q`: the measured points and the fitted power law.
std::string PlotQuantity(const ScalingQuantity& q) {
  job::SvgFigure figure;
  figure.title = q.name + (q.fit.valid ? "  (k = " + Format("%.2f", q.fit.exponent) + ")" : "");
  figure.x_label = "features";
  figure.y_label = q.name + " [" + q.unit + "]";
  figure.width = 640;
  figure.height = 400;
  figure.log_x = figure.log_y = true;
  job::SvgSeries measured{"measured", job::SeriesColour(0), job::SvgSeries::Style::kLine, 1.5,
                          false, q.features, q.values};
  job::SvgSeries points = measured;
  points.name.clear();
  points.style = job::SvgSeries::Style::kPoints;
  points.width = 4;
  figure.series = {measured, points};
  if (q.fit.valid && !q.features.empty()) {
    const auto [lo, hi] = std::minmax_element(q.features.begin(), q.features.end());
    job::SvgSeries fit{"c N^k", job::SeriesColour(1), job::SvgSeries::Style::kLine, 1.5, true,
                       {*lo, *hi}, {}};
    for (double n : fit.x) fit.y.push_back(q.fit.coefficient * std::pow(n, q.fit.exponent));
    figure.series.push_back(fit);
  }
  return job::RenderSvg(figure);
}

std::string Html(const std::vector<ScalingRow>& rows, const std::vector<ScalingQuantity>& quantities,
                 const nlohmann::json& proportion) {
  std::ostringstream html;
  html << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>graphslam scaling "
          "benchmark</title><style>body{font-family:sans-serif;margin:1.5em;max-width:1400px}"
          "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;"
          "text-align:right}.wrap{overflow-x:auto}.plots{display:flex;flex-wrap:wrap;gap:12px}"
          "figure{width:640px;max-width:100%;margin:0}</style></head><body><h1>Scaling benchmark</h1>\n";
  html << "<p>One proportion at every size: " << proportion.dump()
       << ". Each size is simulated, ingested and solved with default options "
          "(<code>graphslam benchmark</code>, docs/benchmarks.md).</p>\n";
  html << "<h2>Fitted exponents</h2><table><tr><th>quantity</th><th>k in y ~ c&middot;N^k</th>"
          "<th>points</th></tr>\n";
  for (const ScalingQuantity& q : quantities)
    html << "<tr><td style=\"text-align:left\">" << q.name << "</td><td>"
         << (q.fit.valid ? Format("%.2f", q.fit.exponent) : std::string("-")) << "</td><td>"
         << q.fit.points << "</td></tr>\n";
  html << "</table>\n<h2>Results</h2><div class=\"wrap\"><table><tr><th>features</th><th>poses"
          "</th><th>observations</th><th>ingest s</th><th>solve s</th><th>end to end s</th>"
          "<th>iterations</th><th>s / iteration</th><th>ingest peak MiB</th><th>solve peak "
          "MiB</th><th>store MiB</th><th>chi2 / dof</th><th>termination</th></tr>\n";
  for (const ScalingRow& r : rows)
    html << "<tr><td>" << r.features << "</td><td>" << r.poses << "</td><td>" << r.observations
         << "</td><td>" << Format("%.3g", r.ingest_seconds) << "</td><td>"
         << Format("%.3g", r.solve_seconds) << "</td><td>" << Format("%.3g", r.end_to_end_seconds())
         << "</td><td>" << r.iterations << "</td><td>" << Format("%.3g", r.seconds_per_iteration)
         << "</td><td>" << Format("%.0f", r.ingest_peak_rss_bytes / kMiB) << "</td><td>"
         << Format("%.0f", r.solve_peak_rss_bytes / kMiB) << "</td><td>"
         << Format("%.1f", r.store_bytes / kMiB) << "</td><td>" << Format("%.4f", r.chi2_per_dof)
         << "</td><td>" << r.termination << "</td></tr>\n";
  html << "</table></div>\n<h2>Plots</h2><div class=\"plots\">\n";
  for (const ScalingQuantity& q : quantities)
    html << "<figure data-quantity=\"" << job::EscapeXml(q.name) << "\">" << PlotQuantity(q)
         << "</figure>\n";
  html << "</div></body></html>\n";
  return html.str();
}

}  // namespace

std::vector<ScalingQuantity> ScalingQuantities(const std::vector<ScalingRow>& rows) {
  std::vector<ScalingQuantity> q = {{"end-to-end seconds", "s", {}, {}, {}},
                                    {"seconds per iteration", "s", {}, {}, {}},
                                    {"peak RSS", "MiB", {}, {}, {}},
                                    {"store bytes", "MiB", {}, {}, {}}};
  for (const ScalingRow& r : rows) {
    const double values[4] = {r.end_to_end_seconds(), r.seconds_per_iteration,
                              std::max(r.ingest_peak_rss_bytes, r.solve_peak_rss_bytes) / kMiB,
                              r.store_bytes / kMiB};
    for (int k = 0; k < 4; ++k) {
      q[k].features.push_back(static_cast<double>(r.features));
      q[k].values.push_back(values[k]);
    }
  }
  for (ScalingQuantity& quantity : q) quantity.fit = FitPowerLaw(quantity.features, quantity.values);
  return q;
}

std::string ScalingCsv(const std::vector<ScalingRow>& rows) {
  std::ostringstream csv;
  csv.precision(10);
  csv << "features,poses,observations,simulate_seconds,ingest_seconds,solve_seconds,"
         "end_to_end_seconds,ingest_cpu_seconds,solve_cpu_seconds,iterations,"
         "seconds_per_iteration,ingest_peak_rss_bytes,solve_peak_rss_bytes,store_bytes,"
         "chi2_per_dof,termination\n";
  for (const ScalingRow& r : rows)
    csv << r.features << ',' << r.poses << ',' << r.observations << ',' << r.simulate_seconds
        << ',' << r.ingest_seconds << ',' << r.solve_seconds << ',' << r.end_to_end_seconds()
        << ',' << r.ingest_cpu_seconds << ',' << r.solve_cpu_seconds << ',' << r.iterations << ','
        << r.seconds_per_iteration << ',' << r.ingest_peak_rss_bytes << ','
        << r.solve_peak_rss_bytes << ',' << r.store_bytes << ',' << r.chi2_per_dof << ','
        << r.termination << '\n';
  return csv.str();
}

Status WriteScalingResults(const std::string& output, const std::vector<ScalingRow>& rows,
                           const nlohmann::json& proportion) {
  storage::Env* env = storage::Env::Default();
  GS_RETURN_IF_ERROR(storage::WriteStringAtomically(env, output + "/scaling.csv", ScalingCsv(rows)));
  return storage::WriteStringAtomically(env, output + "/scaling.html",
                                        Html(rows, ScalingQuantities(rows), proportion));
}

}  // namespace graphslam::tools::benchmark
