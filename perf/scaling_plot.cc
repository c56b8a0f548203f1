// scaling_plot CSV PNG: the scaling benchmark's figure (perf/scaling_benchmark.sh).
//
// Reads the CSV the script writes (header line, then one row per size:
// features,observed_features,poses,observations,ingest_seconds,
// seconds_per_iteration,ingest_peak_rss_bytes,solve_peak_rss_bytes,store_bytes,...)
// and draws, log-log against the number of features, ingest seconds, seconds
// per iteration, peak RSS (MiB) and bytes on disk (MiB), with PLplot's
// pngcairo driver.
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
  if (const int exit_code = graphslam::perf::ReadPlotCsv(argc, argv, "scaling_plot", &columns, &rows))
    return exit_code;
  const char* required[] = {"features", "ingest_seconds", "seconds_per_iteration",
                            "solve_peak_rss_bytes", "ingest_peak_rss_bytes", "store_bytes"};
  for (const char* name : required) {
    if (columns[name].size() != static_cast<size_t>(rows)) {
      std::fprintf(stderr, "%s: column %s missing or short\n", argv[1], name);
      return 2;
    }
  }
  if (rows == 0) {
    std::fprintf(stderr, "%s: no rows\n", argv[1]);
    return 2;
  }
  struct Series {
    const char* column;
    const char* label;
    double scale;
    int red, green, blue;  // readable on white
  };
  const Series series[] = {
      {"ingest_seconds", "ingest s", 1.0, 200, 30, 30},
      {"seconds_per_iteration", "s / iteration", 1.0, 20, 120, 20},
      {"ingest_peak_rss_bytes", "ingest peak RSS MiB", 1.0 / (1 << 20), 30, 60, 200},
      {"solve_peak_rss_bytes", "solve peak RSS MiB", 1.0 / (1 << 20), 150, 40, 160},
      {"store_bytes", "store MiB on disk", 1.0 / (1 << 20), 200, 120, 0}};
  const std::vector<double>& features = columns["features"];
  std::vector<double> x(rows);
  for (int r = 0; r < rows; ++r) x[r] = std::log10(features[r]);
  graphslam::perf::LogLogFigure figure{"graphslam out of core: ingest, solve, memory, disk",
                                       "features (log10)", "value (log10)",
                                       *std::min_element(x.begin(), x.end()),
                                       *std::max_element(x.begin(), x.end()), {}};
  for (const Series& s : series) {
    graphslam::perf::LogLogSeries drawn{s.label, s.red, s.green, s.blue, {}, {}};
    for (int r = 0; r < rows; ++r) {
      const double v = columns[s.column][r] * s.scale;
      if (v > 0) {
        drawn.x.push_back(x[r]);
        drawn.y.push_back(std::log10(v));
      }
    }
    figure.series.push_back(std::move(drawn));
  }
  graphslam::perf::DrawLogLogPng(argv[2], figure);
  return 0;
}
