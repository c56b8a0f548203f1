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

namespace {

// Slope of the least-squares line through (x, y).
double Slope(const std::vector<double>& x, const std::vector<double>& y) {
  const double n = static_cast<double>(x.size());
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    sx += x[i];
    sy += y[i];
    sxx += x[i] * x[i];
    sxy += x[i] * y[i];
  }
  return (n * sxy - sx * sy) / (n * sxx - sx * sx);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: initialization_plot CSV PNG\n");
    return 1;
  }
  std::map<std::string, std::vector<double>> columns;
  int rows = 0;
  if (!graphslam::perf::ReadCsvColumns(argv[1], &columns, &rows)) {
    std::fprintf(stderr, "%s: empty\n", argv[1]);
    return 2;
  }
  for (const char* name : {"poses", "incremental_cpu_seconds", "progressive_cpu_seconds"}) {
    if (columns[name].size() != static_cast<size_t>(rows) || rows == 0) {
      std::fprintf(stderr, "%s: column %s missing or short\n", argv[1], name);
      return 2;
    }
  }
  struct Series {
    const char* column;
    const char* name;
    int color;
  };
  const Series series[] = {{"incremental_cpu_seconds", "incremental (default)", 1},
                           {"progressive_cpu_seconds", "progressive", 2}};
  const std::vector<double>& poses = columns["poses"];
  double xmin = 1e300, xmax = -1e300, ymin = 1e300, ymax = -1e300;
  for (const Series& s : series)
    for (int r = 0; r < rows; ++r)
      if (columns[s.column][r] > 0) {
        xmin = std::min(xmin, std::log10(poses[r]));
        xmax = std::max(xmax, std::log10(poses[r]));
        ymin = std::min(ymin, std::log10(columns[s.column][r]));
        ymax = std::max(ymax, std::log10(columns[s.column][r]));
      }
  plsdev("pngcairo");
  plsfnam(argv[2]);
  plspage(0, 0, 900, 600, 0, 0);
  plscolbg(255, 255, 255);
  plinit();
  plscol0(15, 0, 0, 0);
  plscol0(1, 200, 30, 30);
  plscol0(2, 30, 60, 200);
  plcol0(15);
  plenv(xmin - 0.2, xmax + 0.2, std::floor(ymin) - 0.2, std::ceil(ymax) + 0.2, 0, 30);
  pllab("poses", "CPU seconds", "graphslam: initialization time against poses");
  int n = 0;
  std::vector<std::string> labels;
  labels.reserve(2);
  const char* texts[2];
  PLINT colors[2], line_styles[2], opts[2], symbol_numbers[2];
  PLFLT widths[2], symbol_scales[2];
  const char* symbols[2];
  for (const Series& s : series) {
    std::vector<double> xs, ys, fit_x, fit_y;
    for (int r = 0; r < rows; ++r) {
      const double v = columns[s.column][r];
      if (v <= 0) continue;
      xs.push_back(std::log10(poses[r]));
      ys.push_back(std::log10(v));
      if (poses[r] >= 1e4) {
        fit_x.push_back(xs.back());
        fit_y.push_back(ys.back());
      }
    }
    if (xs.empty()) continue;
    plcol0(s.color);
    plline(static_cast<PLINT>(xs.size()), xs.data(), ys.data());
    plpoin(static_cast<PLINT>(xs.size()), xs.data(), ys.data(), 17);
    char label[128];
    if (fit_x.size() >= 2)
      std::snprintf(label, sizeof(label), "%s: exponent %.2f", s.name, Slope(fit_x, fit_y));
    else
      std::snprintf(label, sizeof(label), "%s", s.name);
    labels.emplace_back(label);
    texts[n] = labels.back().c_str();
    colors[n] = s.color;
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
           colors, line_styles, widths, colors, symbol_scales, symbol_numbers, symbols);
  plend();
  return 0;
}
