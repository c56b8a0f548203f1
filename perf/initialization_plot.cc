// initialization_plot CSV PNG: the initialization scaling figure
// (perf/initialization_scaling.py).
//
// Reads the CSV the script writes (header line, then one row per size with at
// least the columns poses, incremental_cpu_seconds, progressive_cpu_seconds;
// a value <= 0 means "not measured") and draws, log-log against the number of
// poses, the CPU seconds of each initialization with PLplot's pngcairo
// driver. The legend gives each series' fitted exponent b of t = a N^b, the
// least-squares line through (log N, log t) of its sizes from 10^4 poses on
// (below, fixed costs dominate).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "perf/log_log_plot.h"

int main(int argc, char** argv) {
  std::map<std::string, std::vector<double>> columns;
  int rows = 0;
  if (const int exit_code = graphslam::perf::ReadPlotCsv(argc, argv, "initialization_plot", &columns, &rows))
    return exit_code;
  for (const char* name : {"poses", "incremental_cpu_seconds", "progressive_cpu_seconds"}) {
    if (columns[name].size() != static_cast<size_t>(rows) || rows == 0) {
      std::fprintf(stderr, "%s: column %s missing or short\n", argv[1], name);
      return 2;
    }
  }
  struct Series {
    const char* column;
    const char* name;
    int red, green, blue;
  };
  const Series series[] = {{"incremental_cpu_seconds", "incremental (default)", 200, 30, 30},
                           {"progressive_cpu_seconds", "progressive", 30, 60, 200}};
  const std::vector<double>& poses = columns["poses"];
  graphslam::perf::LogLogFigure figure{"graphslam: initialization time against poses", "poses",
                                       "CPU seconds", 1e300, -1e300, {}};
  for (const Series& s : series) {
    graphslam::perf::LogLogSeries drawn{s.name, s.red, s.green, s.blue, {}, {}};
    std::vector<double> fit_x, fit_y;
    for (int r = 0; r < rows; ++r) {
      const double v = columns[s.column][r];
      if (v <= 0) continue;
      drawn.x.push_back(std::log10(poses[r]));
      drawn.y.push_back(std::log10(v));
      figure.xmin = std::min(figure.xmin, drawn.x.back());
      figure.xmax = std::max(figure.xmax, drawn.x.back());
      if (poses[r] >= 1e4) {
        fit_x.push_back(drawn.x.back());
        fit_y.push_back(drawn.y.back());
      }
    }
    if (drawn.x.empty()) continue;
    char label[128];
    if (fit_x.size() >= 2) {
      std::snprintf(label, sizeof(label), "%s: exponent %.2f", s.name,
                    graphslam::perf::LeastSquaresSlope(fit_x, fit_y));
      drawn.label = label;
    }
    figure.series.push_back(std::move(drawn));
  }
  graphslam::perf::DrawLogLogPng(argv[2], figure);
  return 0;
}
