// scaling_plot CSV PNG: the scaling benchmark's figure (perf/scaling_benchmark.sh).
//
// Reads the CSV the script writes (header line, then one row per size:
// features,observed_features,poses,observations,ingest_seconds,
// seconds_per_iteration,ingest_peak_rss_bytes,solve_peak_rss_bytes,store_bytes,...)
// and draws, log-log against the number of features, ingest seconds, seconds
// per iteration, peak RSS (MiB) and bytes on disk (MiB), with PLplot's
// pngcairo driver.
#include <plplot.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "perf/csv_columns.h"

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: scaling_plot CSV PNG\n");
    return 1;
  }
  std::map<std::string, std::vector<double>> columns;
  int rows = 0;
  if (!graphslam::perf::ReadCsvColumns(argv[1], &columns, &rows)) {
    std::fprintf(stderr, "%s: empty\n", argv[1]);
    return 2;
  }
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
    int color;
  };
  // Colors 1..5 (set below, readable on white); 15 is the axes' black.
  const Series series[] = {{"ingest_seconds", "ingest s", 1.0, 1},
                           {"seconds_per_iteration", "s / iteration", 1.0, 2},
                           {"ingest_peak_rss_bytes", "ingest peak RSS MiB", 1.0 / (1 << 20), 3},
                           {"solve_peak_rss_bytes", "solve peak RSS MiB", 1.0 / (1 << 20), 4},
                           {"store_bytes", "store MiB on disk", 1.0 / (1 << 20), 5}};
  double ymin = 1e300, ymax = -1e300;
  const std::vector<double>& features = columns["features"];
  std::vector<double> x(rows);
  for (int r = 0; r < rows; ++r) x[r] = std::log10(features[r]);
  for (const Series& s : series)
    for (double v : columns[s.column])
      if (v * s.scale > 0) {
        ymin = std::min(ymin, std::log10(v * s.scale));
        ymax = std::max(ymax, std::log10(v * s.scale));
      }
  plsdev("pngcairo");
  plsfnam(argv[2]);
  plspage(0, 0, 900, 600, 0, 0);
  plscolbg(255, 255, 255);
  plinit();
  plscol0(15, 0, 0, 0);
  plscol0(1, 200, 30, 30);
  plscol0(2, 20, 120, 20);
  plscol0(3, 30, 60, 200);
  plscol0(4, 150, 40, 160);
  plscol0(5, 200, 120, 0);
  plcol0(15);
  plenv(*std::min_element(x.begin(), x.end()) - 0.2, *std::max_element(x.begin(), x.end()) + 0.2,
        std::floor(ymin) - 0.2, std::ceil(ymax) + 0.2, 0, 30);
  pllab("features (log10)", "value (log10)",
        "graphslam out of core: ingest, solve, memory, disk");
  int n = 0;
  const char* texts[5];
  PLINT colors[5], line_styles[5], opts[5], symbol_colors[5];
  PLFLT widths[5], symbol_scales[5];
  PLINT symbol_numbers[5];
  const char* symbols[5];
  for (const Series& s : series) {
    std::vector<double> xs, ys;
    for (int r = 0; r < rows; ++r) {
      const double v = columns[s.column][r] * s.scale;
      if (v > 0) {
        xs.push_back(x[r]);
        ys.push_back(std::log10(v));
      }
    }
    plcol0(s.color);
    plline(static_cast<PLINT>(xs.size()), xs.data(), ys.data());
    plpoin(static_cast<PLINT>(xs.size()), xs.data(), ys.data(), 17);
    texts[n] = s.label;
    colors[n] = s.color;
    symbol_colors[n] = s.color;
    line_styles[n] = 1;
    widths[n] = 1.0;
    opts[n] = PL_LEGEND_LINE | PL_LEGEND_SYMBOL;
    symbol_scales[n] = 1.0;
    symbol_numbers[n] = 1;
    symbols[n] = "#(728)";
    ++n;
  }
  PLFLT legend_width = 0, legend_height = 0;
  plcol0(15);
  pllegend(&legend_width, &legend_height, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX,
           PL_POSITION_TOP | PL_POSITION_LEFT | PL_POSITION_INSIDE, 0.02, 0.02, 0.1, 0, 15, 1, 0,
           0, n, opts, 1.0, 1.0, 2.0, 1.0, colors, texts, nullptr, nullptr, nullptr, nullptr,
           colors, line_styles, widths, symbol_colors, symbol_scales, symbol_numbers, symbols);
  plend();
  return 0;
}
