#include "tools/benchmark/scaling_report.h"

#include <plplot/plstream.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "storage/atomic_file.h"
#include "tools/job/report_html.h"

namespace graphslam::tools::benchmark {
namespace {

constexpr double kMiB = 1024.0 * 1024.0;

std::string Format(const char* format, double value) {
  char text[64];
  std::snprintf(text, sizeof(text), format, value);
  return text;
}

// A log-log PNG of `q` (points and the fitted line), via PLplot's pngcairo.
StatusOr<std::string> PlotQuantity(const ScalingQuantity& q, const std::string& scratch) {
  std::vector<double> lx, ly;
  for (size_t i = 0; i < q.features.size(); ++i) {
    if (!(q.features[i] > 0) || !(q.values[i] > 0)) continue;
    lx.push_back(std::log10(q.features[i]));
    ly.push_back(std::log10(q.values[i]));
  }
  if (lx.empty()) return std::string();
  const auto [x0, x1] = std::minmax_element(lx.begin(), lx.end());
  const auto [y0, y1] = std::minmax_element(ly.begin(), ly.end());
  const double xmin = *x0 - 0.2, xmax = *x1 + 0.2;
  const double ymin = *y0 - 0.3, ymax = *y1 + 0.3;
  {
    auto pls = std::make_unique<plstream>();
    pls->sdev("pngcairo");
    pls->sfnam(scratch.c_str());
    pls->spage(0, 0, 640, 440, 0, 0);
    pls->scolbg(255, 255, 255);
    pls->init();
    pls->scol0(1, 0, 0, 0);
    pls->scol0(2, 31, 119, 180);
    pls->scol0(3, 214, 39, 40);
    pls->col0(1);
    pls->env(xmin, xmax, ymin, ymax, 0, 30);  // log x, log y
    const std::string title =
        q.name + (q.fit.valid ? "  (k = " + Format("%.2f", q.fit.exponent) + ")" : "");
    pls->lab("features", (q.name + " [" + q.unit + "]").c_str(), title.c_str());
    pls->col0(2);
    pls->poin(static_cast<PLINT>(lx.size()), lx.data(), ly.data(), 17);
    pls->line(static_cast<PLINT>(lx.size()), lx.data(), ly.data());
    if (q.fit.valid) {
      double fx[2] = {*x0, *x1};
      double fy[2];
      for (int k = 0; k < 2; ++k) fy[k] = std::log10(q.fit.coefficient) + q.fit.exponent * fx[k];
      pls->col0(3);
      pls->lsty(2);
      pls->line(2, fx, fy);
    }
  }  // plend1: the file is complete
  std::ifstream in(scratch, std::ios::binary);
  std::stringstream bytes;
  bytes << in.rdbuf();
  std::error_code error;
  std::filesystem::remove(scratch, error);
  if (bytes.str().size() < 8) return Status::IOError(scratch + ": PLplot wrote no PNG");
  return bytes.str();
}

std::string Html(const std::vector<ScalingRow>& rows, const std::vector<ScalingQuantity>& quantities,
                 const std::vector<std::string>& images, const nlohmann::json& proportion) {
  std::ostringstream html;
  html << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>graphslam scaling "
          "benchmark</title><style>body{font-family:sans-serif;margin:1.5em;max-width:1400px}"
          "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 8px;"
          "text-align:right}.wrap{overflow-x:auto}.plots{display:flex;flex-wrap:wrap;gap:12px}"
          "img{max-width:100%}</style></head><body><h1>Scaling benchmark</h1>\n";
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
  for (size_t i = 0; i < images.size(); ++i)
    if (!images[i].empty())
      html << "<figure><img alt=\"" << quantities[i].name << "\" src=\"data:image/png;base64,"
           << job::Base64(images[i]) << "\"></figure>\n";
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
  const std::vector<ScalingQuantity> quantities = ScalingQuantities(rows);
  std::vector<std::string> images;
  for (size_t i = 0; i < quantities.size(); ++i) {
    GS_ASSIGN_OR_RETURN(std::string png,
                        PlotQuantity(quantities[i], output + "/.benchmark/plot.png"));
    images.push_back(std::move(png));
  }
  return storage::WriteStringAtomically(env, output + "/scaling.html",
                                        Html(rows, quantities, images, proportion));
}

}  // namespace graphslam::tools::benchmark
