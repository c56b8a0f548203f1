// Figures of the job report as inline SVG (no script, no external file): one
// plot area with axes, ticks and grid, data drawn in the order given (later
// on top), and the legend OUTSIDE the plot area, to its right.
//
// Coordinates: the data range is the union of every series, bar and image
// (plus the explicit limits, if set), padded by 3 %; with equal_axes one data
// unit has the same length on both axes (maps). A log y axis plots log10(y)
// and drops y <= 0; a log x axis (series only, not bars or images) the same
// for x. Ticks: 1, 2 or 5 times a power of ten, about 6 per axis;
// on a log axis the powers of ten.
//
// The SVG scales with its container (viewBox, width 100 %); the plot area is
// <rect class="plot-area" x= y= width= height=> and the legend
// <g class="legend" transform="translate(X,Y)">, so a reader (or a test) can
// check where they are.
//
// THREAD SAFETY: pure functions. ALLOCATION: O(points).
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace graphslam::tools::job {

struct SvgSeries {
  enum class Style { kLine, kPoints, kCrosses };
  std::string name;    // legend text; empty: not in the legend
  std::string colour;  // CSS colour, e.g. "#1f77b4"
  Style style = Style::kLine;
  double width = 1.5;  // line width or marker radius, px
  bool dashed = false;
  std::vector<double> x, y;
};

// Bars [left, right] x [0, height], for histograms.
struct SvgBars {
  std::string name;
  std::string colour;
  std::vector<double> left, right, height;
};

// A raster (PNG bytes) covering the data rectangle [x0, x1] x [y0, y1].
struct SvgImage {
  std::string png;
  double x0 = 0, x1 = 1, y0 = 0, y1 = 1;
};

struct SvgFigure {
  std::string title, x_label, y_label;
  int width = 900, height = 480;  // viewBox, px
  bool log_y = false;
  bool log_x = false;
  bool equal_axes = false;
  std::optional<double> x_min, x_max, y_min, y_max;  // forced limits
  std::optional<SvgImage> image;  // drawn first
  std::vector<SvgBars> bars;      // then the bars
  std::vector<SvgSeries> series;  // then the series, in order
  // Extra legend entries without data (e.g. the colours of a raster).
  std::vector<std::pair<std::string, std::string>> legend_only;  // (name, colour)
};

std::string RenderSvg(const SvgFigure& figure);

// The palette of runs / components: colour i (cycling through 8).
std::string SeriesColour(size_t i);

// Text with & < > " escaped for HTML / SVG.
std::string EscapeXml(const std::string& text);

}  // namespace graphslam::tools::job
