#include "perf/log_log_plot.h"

#include <plplot.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "perf/csv_columns.h"

namespace graphslam::perf {

double LeastSquaresSlope(const std::vector<double>& x, const std::vector<double>& y) {
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

int ReadPlotCsv(int argc, char** argv, const char* name,
                std::map<std::string, std::vector<double>>* columns, int* rows) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s CSV PNG\n", name);
    return 1;
  }
  if (!ReadCsvColumns(argv[1], columns, rows)) {
    std::fprintf(stderr, "%s: empty\n", argv[1]);
    return 2;
  }
  return 0;
}

void DrawLogLogPng(const char* path, const LogLogFigure& figure) {
  constexpr int kBlack = 15;  // colours 1..n are the series'
  double ymin = 1e300, ymax = -1e300;
  for (const LogLogSeries& s : figure.series)
    for (double y : s.y) {
      ymin = std::min(ymin, y);
      ymax = std::max(ymax, y);
    }
  plsdev("pngcairo");
  plsfnam(path);
  plspage(0, 0, 900, 600, 0, 0);
  plscolbg(255, 255, 255);
  plinit();
  plscol0(kBlack, 0, 0, 0);
  const int n = static_cast<int>(figure.series.size());
  for (int i = 0; i < n; ++i)
    plscol0(i + 1, figure.series[i].red, figure.series[i].green, figure.series[i].blue);
  plcol0(kBlack);
  plenv(figure.xmin - 0.2, figure.xmax + 0.2, std::floor(ymin) - 0.2, std::ceil(ymax) + 0.2, 0,
        30);
  pllab(figure.x_label.c_str(), figure.y_label.c_str(), figure.title.c_str());
  std::vector<const char*> texts(n), symbols(n, "#(728)");
  std::vector<PLINT> colors(n), line_styles(n, 1), opts(n, PL_LEGEND_LINE | PL_LEGEND_SYMBOL),
      symbol_numbers(n, 1);
  std::vector<PLFLT> widths(n, 1.0), symbol_scales(n, 1.0);
  for (int i = 0; i < n; ++i) {
    const LogLogSeries& s = figure.series[i];
    colors[i] = i + 1;
    plcol0(colors[i]);
    plline(static_cast<PLINT>(s.x.size()), s.x.data(), s.y.data());
    plpoin(static_cast<PLINT>(s.x.size()), s.x.data(), s.y.data(), 17);
    texts[i] = s.label.c_str();
  }
  PLFLT legend_width = 0, legend_height = 0;
  plcol0(kBlack);
  pllegend(&legend_width, &legend_height, PL_LEGEND_BACKGROUND | PL_LEGEND_BOUNDING_BOX,
           PL_POSITION_TOP | PL_POSITION_LEFT | PL_POSITION_INSIDE, 0.02, 0.02, 0.1, 0, kBlack, 1,
           0, 0, n, opts.data(), 1.0, 1.0, 2.0, 1.0, colors.data(), texts.data(), nullptr,
           nullptr, nullptr, nullptr, colors.data(), line_styles.data(), widths.data(),
           colors.data(), symbol_scales.data(), symbol_numbers.data(), symbols.data());
  plend();
}

}  // namespace graphslam::perf
