#include "tools/job/plots.h"

#include <plplot/plstream.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>

namespace graphslam::tools::job {
namespace {

constexpr int kWidth = 900;
constexpr int kHeight = 700;

// A white-background pngcairo stream writing `path`, with a palette of
// distinguishable colours in cmap0 slots 1..8 (0 is the background).
std::unique_ptr<plstream> OpenStream(const std::string& path, int width, int height) {
  auto pls = std::make_unique<plstream>();
  pls->sdev("pngcairo");
  pls->sfnam(path.c_str());
  pls->spage(0, 0, width, height, 0, 0);
  pls->scolbg(255, 255, 255);
  pls->init();
  pls->scol0(1, 0, 0, 0);         // axes: black
  pls->scol0(2, 31, 119, 180);    // blue
  pls->scol0(3, 214, 39, 40);     // red
  pls->scol0(4, 44, 160, 44);     // green
  pls->scol0(5, 148, 103, 189);   // purple
  pls->scol0(6, 255, 127, 14);    // orange
  pls->scol0(7, 140, 86, 75);     // brown
  pls->scol0(8, 23, 190, 207);    // cyan
  pls->scol0(14, 170, 170, 170);  // grey (ground truth, features)
  pls->scol0(15, 230, 171, 2);    // GPS: amber
  return pls;
}

int SeriesColour(size_t i) { return 2 + static_cast<int>(i % 7); }

// Finishes the stream and returns the file's bytes.
StatusOr<std::string> Finish(std::unique_ptr<plstream> pls, const std::string& path) {
  pls.reset();  // plend1: flushes and closes the file
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::IOError("PLplot wrote no image to " + path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  std::error_code error;
  std::filesystem::remove(path, error);
  std::string bytes = buffer.str();
  if (bytes.size() < 8 || bytes.compare(1, 3, "PNG") != 0)
    return Status::IOError(path + ": PLplot did not write a PNG");
  return bytes;
}

void Extend(const XySeries& s, double* x0, double* x1, double* y0, double* y1) {
  for (size_t i = 0; i < s.x.size(); ++i) {
    *x0 = std::min(*x0, s.x[i]);
    *x1 = std::max(*x1, s.x[i]);
    *y0 = std::min(*y0, s.y[i]);
    *y1 = std::max(*y1, s.y[i]);
  }
}

// A legend of coloured names stacked in the top-left corner of the viewport.
void Legend(plstream* pls, const std::vector<std::pair<std::string, int>>& entries) {
  pls->schr(0, 0.8);
  double position = 1.0;
  for (const auto& [name, colour] : entries) {
    pls->col0(colour);
    pls->mtex("lv", -1.0, position - 0.03, 0.0, name.c_str());
    position -= 0.035;
  }
  pls->schr(0, 1.0);
  pls->col0(1);
}

}  // namespace

StatusOr<std::string> PlotTrajectories(const TrajectoryPlot& plot, const std::string& scratch) {
  double x0 = std::numeric_limits<double>::infinity(), x1 = -x0, y0 = x0, y1 = -x0;
  for (const XySeries& s : plot.estimated) Extend(s, &x0, &x1, &y0, &y1);
  for (const XySeries& s : plot.ground_truth) Extend(s, &x0, &x1, &y0, &y1);
  Extend(plot.gps, &x0, &x1, &y0, &y1);
  Extend(plot.features, &x0, &x1, &y0, &y1);
  if (!std::isfinite(x0)) x0 = -1, x1 = 1, y0 = -1, y1 = 1;
  const double margin = 0.05 * std::max({x1 - x0, y1 - y0, 1.0});
  auto pls = OpenStream(scratch, kWidth, kHeight);
  pls->col0(1);
  pls->env(x0 - margin, x1 + margin, y0 - margin, y1 + margin, 1, 0);
  pls->lab("x [m]", "y [m]", plot.title.c_str());
  std::vector<std::pair<std::string, int>> legend;
  if (!plot.features.x.empty()) {
    pls->col0(14);
    pls->poin(static_cast<PLINT>(plot.features.x.size()), plot.features.x.data(),
              plot.features.y.data(), 5);
    legend.emplace_back("x features", 14);
  }
  for (const XySeries& s : plot.ground_truth) {
    pls->col0(14);
    pls->width(0.5);
    pls->line(static_cast<PLINT>(s.x.size()), s.x.data(), s.y.data());
  }
  if (!plot.ground_truth.empty()) legend.emplace_back("- ground truth", 14);
  pls->width(1.5);
  for (size_t i = 0; i < plot.estimated.size(); ++i) {
    const XySeries& s = plot.estimated[i];
    pls->col0(SeriesColour(i));
    pls->line(static_cast<PLINT>(s.x.size()), s.x.data(), s.y.data());
    legend.emplace_back("- " + s.name, SeriesColour(i));
  }
  pls->width(1.0);
  if (!plot.gps.x.empty()) {
    pls->col0(15);
    pls->poin(static_cast<PLINT>(plot.gps.x.size()), plot.gps.x.data(), plot.gps.y.data(), 17);
    legend.emplace_back(". GPS fixes", 15);
  }
  Legend(pls.get(), legend);
  return Finish(std::move(pls), scratch);
}

StatusOr<std::string> PlotConvergence(const std::vector<XySeries>& curves,
                                      const std::string& scratch) {
  double x0 = 0, x1 = 1, y0 = std::numeric_limits<double>::infinity(), y1 = -y0;
  std::vector<XySeries> logs;
  for (const XySeries& c : curves) {
    XySeries l = c;
    for (double& y : l.y) y = std::log10(std::max(y, 1e-300));
    for (double x : l.x) x1 = std::max(x1, x);
    for (double y : l.y) y0 = std::min(y0, y), y1 = std::max(y1, y);
    logs.push_back(std::move(l));
  }
  if (!std::isfinite(y0)) y0 = 0, y1 = 1;
  if (y1 - y0 < 0.1) y0 -= 0.5, y1 += 0.5;
  auto pls = OpenStream(scratch, kWidth, 500);
  pls->col0(1);
  pls->env(x0, x1, y0 - 0.05 * (y1 - y0), y1 + 0.05 * (y1 - y0), 0, 20);  // log y axis
  pls->lab("iteration", "chi2", "Levenberg-Marquardt convergence");
  std::vector<std::pair<std::string, int>> legend;
  pls->width(1.5);
  for (size_t i = 0; i < logs.size(); ++i) {
    pls->col0(SeriesColour(i));
    if (logs[i].x.size() > 1)
      pls->line(static_cast<PLINT>(logs[i].x.size()), logs[i].x.data(), logs[i].y.data());
    pls->poin(static_cast<PLINT>(logs[i].x.size()), logs[i].x.data(), logs[i].y.data(), 17);
    legend.emplace_back(logs[i].name, SeriesColour(i));
  }
  Legend(pls.get(), legend);
  return Finish(std::move(pls), scratch);
}

StatusOr<std::string> PlotStages(const std::vector<StageBar>& stages, const std::string& scratch) {
  const auto n = static_cast<double>(std::max<size_t>(stages.size(), 1));
  double top = 1e-3;
  for (const StageBar& s : stages) top = std::max(top, s.seconds);
  auto pls = OpenStream(scratch, kWidth, 450);
  pls->col0(1);
  pls->adv(0);
  pls->vsta();
  pls->wind(0, n, 0, top * 1.25);
  pls->box("bc", 0, 0, "bcnstv", 0, 0);  // stage names instead of x ticks
  pls->lab("", "wall time [s]", "Time and peak memory per stage");
  for (size_t i = 0; i < stages.size(); ++i) {
    const double left = static_cast<double>(i) + 0.15, right = static_cast<double>(i) + 0.85;
    const double xs[4] = {left, left, right, right};
    const double ys[4] = {0, stages[i].seconds, stages[i].seconds, 0};
    pls->col0(2);
    pls->fill(4, xs, ys);
    pls->col0(1);
    char label[64];
    std::snprintf(label, sizeof(label), "%.2f s", stages[i].seconds);
    pls->ptex(static_cast<double>(i) + 0.5, stages[i].seconds + top * 0.11, 1, 0, 0.5, label);
    std::snprintf(label, sizeof(label), "%.0f MiB", stages[i].peak_rss_mib);
    pls->ptex(static_cast<double>(i) + 0.5, stages[i].seconds + top * 0.03, 1, 0, 0.5, label);
    pls->mtex("b", 3.2, (static_cast<double>(i) + 0.5) / n, 0.5, stages[i].stage.c_str());
  }
  return Finish(std::move(pls), scratch);
}

}  // namespace graphslam::tools::job
