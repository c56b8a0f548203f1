#include "tools/job/svg_figure.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <sstream>

#include "tools/job/report_html.h"

namespace graphslam::tools::job {
namespace {

constexpr double kLeft = 72, kTop = 34, kBottom = 48;
// Legend column: marker, gap, text of ~7.2 px per character at 13 px.
double LegendWidth(size_t longest_name) {
  return std::min(380.0, 64.0 + 7.5 * static_cast<double>(longest_name));
}

std::string Num(double v) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.1f", v);
  return text;
}

std::string TickLabel(double v, bool log) {
  char text[32];
  if (log) {
    std::snprintf(text, sizeof(text), "1e%d", static_cast<int>(std::lround(v)));
  } else {
    if (std::abs(v) < 1e-12) v = 0;
    std::snprintf(text, sizeof(text), "%g", v);
  }
  return text;
}

std::vector<double> Ticks(double lo, double hi, bool log) {
  std::vector<double> ticks;
  if (log) {
    int step = std::max(1, static_cast<int>(std::ceil((hi - lo) / 8.0)));
    for (int e = static_cast<int>(std::ceil(lo)); e <= std::floor(hi); e += step) ticks.push_back(e);
    return ticks;
  }
  const double raw = (hi - lo) / 6.0;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  double step = power;
  for (double m : {1.0, 2.0, 5.0, 10.0})
    if (m * power >= raw) {
      step = m * power;
      break;
    }
  for (double t = std::ceil(lo / step) * step; t <= hi + 1e-9 * step; t += step) ticks.push_back(t);
  return ticks;
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void Add(double v) {
    if (std::isfinite(v)) lo = std::min(lo, v), hi = std::max(hi, v);
  }
  bool Valid() const { return lo <= hi; }
};

// Data to pixels: the axes' ranges (log10 on a log axis) and the plot area.
struct Frame {
  bool log_x = false, log_y = false;
  Range xr, yr;
  double area_x = kLeft, area_y = kTop, area_w = 0, area_h = 0;
  bool has_legend = false;

  // A data value on the axis (log10 on a log axis; NaN where undefined).
  double XOf(double x) const { return log_x ? (x > 0 ? std::log10(x) : NAN) : x; }
  double YOf(double y) const { return log_y ? (y > 0 ? std::log10(y) : NAN) : y; }
  // An axis value in pixels.
  double Px(double x) const { return area_x + (x - xr.lo) / (xr.hi - xr.lo) * area_w; }
  double Py(double y) const { return area_y + area_h - (y - yr.lo) / (yr.hi - yr.lo) * area_h; }
};

// The ranges that hold every finite value of the figure, its fixed limits,
// a 3 % margin on the free ends; the plot area beside the legend.
Frame FitFrame(const SvgFigure& f) {
  Frame frame;
  frame.log_x = f.log_x;
  frame.log_y = f.log_y;
  Range& xr = frame.xr;
  Range& yr = frame.yr;
  if (f.image) xr.Add(f.image->x0), xr.Add(f.image->x1), yr.Add(f.image->y0), yr.Add(f.image->y1);
  for (const SvgBars& b : f.bars)
    for (size_t i = 0; i < b.left.size(); ++i)
      xr.Add(b.left[i]), xr.Add(b.right[i]), yr.Add(0), yr.Add(b.height[i]);
  for (const SvgSeries& s : f.series)
    for (size_t i = 0; i < s.x.size(); ++i)
      if (std::isfinite(frame.YOf(s.y[i])) && std::isfinite(frame.XOf(s.x[i])))
        xr.Add(frame.XOf(s.x[i])), yr.Add(frame.YOf(s.y[i]));
  if (!xr.Valid()) xr.lo = 0, xr.hi = 1;
  if (!yr.Valid()) yr.lo = 0, yr.hi = 1;
  if (f.x_min) xr.lo = frame.XOf(*f.x_min);
  if (f.x_max) xr.hi = frame.XOf(*f.x_max);
  if (f.y_min) yr.lo = frame.YOf(*f.y_min);
  if (f.y_max) yr.hi = frame.YOf(*f.y_max);
  if (xr.hi - xr.lo < 1e-12) xr.lo -= 0.5, xr.hi += 0.5;
  if (yr.hi - yr.lo < 1e-12) yr.lo -= 0.5, yr.hi += 0.5;
  const double pad_x = 0.03 * (xr.hi - xr.lo), pad_y = 0.03 * (yr.hi - yr.lo);
  if (!f.x_min) xr.lo -= pad_x;
  if (!f.x_max) xr.hi += pad_x;
  if (!f.y_min) yr.lo -= pad_y;
  if (!f.y_max) yr.hi += pad_y;
  // A log axis within one decade would show no 1eN tick: it is widened to
  // the decades around the data unless the caller fixed its ends.
  const auto whole_decades = [](Range* r, bool fixed_lo, bool fixed_hi) {
    if (std::ceil(r->lo) <= std::floor(r->hi)) return;
    if (!fixed_lo) r->lo = std::floor(r->lo);
    if (!fixed_hi) r->hi = std::ceil(r->hi);
  };
  if (f.log_x) whole_decades(&xr, f.x_min.has_value(), f.x_max.has_value());
  if (f.log_y) whole_decades(&yr, f.y_min.has_value(), f.y_max.has_value());

  size_t longest = 0;
  for (const auto& entry : f.legend_only) longest = std::max(longest, entry.first.size());
  for (const SvgSeries& s : f.series) longest = std::max(longest, s.name.size());
  for (const SvgBars& b : f.bars) longest = std::max(longest, b.name.size());
  frame.has_legend = longest > 0;
  frame.area_w = f.width - kLeft - (frame.has_legend ? LegendWidth(longest) : 20.0);
  frame.area_h = f.height - kTop - kBottom;
  if (f.equal_axes) {
    // Widen the range of the axis that would be stretched.
    const double sx = frame.area_w / (xr.hi - xr.lo), sy = frame.area_h / (yr.hi - yr.lo);
    if (sx > sy) {
      const double extra = frame.area_w / sy - (xr.hi - xr.lo);
      xr.lo -= extra / 2, xr.hi += extra / 2;
    } else {
      const double extra = frame.area_h / sx - (yr.hi - yr.lo);
      yr.lo -= extra / 2, yr.hi += extra / 2;
    }
  }
  return frame;
}

// The svg element, title, clip path, grid, tick labels and axis labels.
void WriteAxes(const SvgFigure& f, const Frame& frame, const std::string& clip,
               std::ostringstream& out) {
  const double area_x = frame.area_x, area_y = frame.area_y;
  const double area_w = frame.area_w, area_h = frame.area_h;
  out << "<svg viewBox=\"0 0 " << f.width << " " << f.height
      << "\" width=\"100%\" role=\"img\" aria-label=\"" << EscapeXml(f.title)
      << "\" font-family=\"sans-serif\" font-size=\"13\">\n";
  out << "<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n";
  out << "<text x=\"" << Num(area_x + area_w / 2) << "\" y=\"20\" text-anchor=\"middle\" "
      << "font-size=\"15\" font-weight=\"bold\">" << EscapeXml(f.title) << "</text>\n";
  out << "<defs><clipPath id=\"" << clip << "\"><rect x=\"" << Num(area_x) << "\" y=\"" << Num(area_y)
      << "\" width=\"" << Num(area_w) << "\" height=\"" << Num(area_h) << "\"/></clipPath></defs>\n";
  // Grid and ticks.
  out << "<g stroke=\"#e4e4e4\">";
  for (double t : Ticks(frame.xr.lo, frame.xr.hi, f.log_x))
    out << "<line x1=\"" << Num(frame.Px(t)) << "\" x2=\"" << Num(frame.Px(t)) << "\" y1=\"" << Num(area_y)
        << "\" y2=\"" << Num(area_y + area_h) << "\"/>";
  for (double t : Ticks(frame.yr.lo, frame.yr.hi, f.log_y))
    out << "<line x1=\"" << Num(area_x) << "\" x2=\"" << Num(area_x + area_w) << "\" y1=\""
        << Num(frame.Py(t)) << "\" y2=\"" << Num(frame.Py(t)) << "\"/>";
  out << "</g>\n<g fill=\"#333\">";
  for (double t : Ticks(frame.xr.lo, frame.xr.hi, f.log_x))
    out << "<text x=\"" << Num(frame.Px(t)) << "\" y=\"" << Num(area_y + area_h + 17)
        << "\" text-anchor=\"middle\">" << TickLabel(t, f.log_x) << "</text>";
  for (double t : Ticks(frame.yr.lo, frame.yr.hi, f.log_y))
    out << "<text x=\"" << Num(area_x - 6) << "\" y=\"" << Num(frame.Py(t) + 4)
        << "\" text-anchor=\"end\">" << TickLabel(t, f.log_y) << "</text>";
  out << "<text x=\"" << Num(area_x + area_w / 2) << "\" y=\"" << Num(f.height - 8.0)
      << "\" text-anchor=\"middle\">" << EscapeXml(f.x_label) << "</text>";
  out << "<text transform=\"translate(16," << Num(area_y + area_h / 2)
      << ") rotate(-90)\" text-anchor=\"middle\">" << EscapeXml(f.y_label) << "</text></g>\n";
}

// The raster image and the bars.
void WriteImageAndBars(const SvgFigure& f, const Frame& frame, std::ostringstream& out) {
  if (f.image) {
    out << "<image class=\"raster\" preserveAspectRatio=\"none\" x=\"" << Num(frame.Px(f.image->x0))
        << "\" y=\"" << Num(frame.Py(f.image->y1)) << "\" width=\"" << Num(frame.Px(f.image->x1) - frame.Px(f.image->x0))
        << "\" height=\"" << Num(frame.Py(f.image->y0) - frame.Py(f.image->y1))
        << "\" style=\"image-rendering:pixelated\" href=\"data:image/png;base64,"
        << Base64(f.image->png) << "\"/>\n";
  }
  for (const SvgBars& b : f.bars) {
    out << "<g class=\"bars\" fill=\"" << b.colour << "\" fill-opacity=\"0.75\">";
    for (size_t i = 0; i < b.left.size(); ++i)
      out << "<rect x=\"" << Num(frame.Px(b.left[i])) << "\" y=\"" << Num(frame.Py(b.height[i])) << "\" width=\""
          << Num(std::max(0.5, frame.Px(b.right[i]) - frame.Px(b.left[i]) - 0.5)) << "\" height=\""
          << Num(frame.Py(0) - frame.Py(b.height[i])) << "\"/>";
    out << "</g>\n";
  }
}

// One series: a path (broken at non-finite values), or points or crosses.
void WriteSeries(const SvgSeries& s, const Frame& frame, std::ostringstream& out) {
  const std::string cls = "series";
  if (s.style == SvgSeries::Style::kLine) {
    out << "<path class=\"" << cls << "\" data-name=\"" << EscapeXml(s.name)
        << "\" fill=\"none\" stroke=\"" << s.colour << "\" stroke-width=\"" << s.width
        << "\" stroke-linejoin=\"round\"" << (s.dashed ? " stroke-dasharray=\"6 4\"" : "")
        << " d=\"";
    bool pen = false;
    for (size_t i = 0; i < s.x.size(); ++i) {
      const double y = frame.YOf(s.y[i]);
      const double x = frame.XOf(s.x[i]);
      if (!std::isfinite(y) || !std::isfinite(x)) {
        pen = false;
        continue;
      }
      out << (pen ? "L" : "M") << Num(frame.Px(x)) << " " << Num(frame.Py(y));
      pen = true;
    }
    out << "\"/>\n";
    return;
  }
  out << "<g class=\"" << cls << "\" data-name=\"" << EscapeXml(s.name) << "\" "
      << (s.style == SvgSeries::Style::kPoints ? "fill=\"" + s.colour + "\""
                                               : "stroke=\"" + s.colour + "\" stroke-width=\"2\"")
      << ">";
  const double r = s.width;
  for (size_t i = 0; i < s.x.size(); ++i) {
    const double y = frame.YOf(s.y[i]);
    const double x = frame.XOf(s.x[i]);
    if (!std::isfinite(y) || !std::isfinite(x)) continue;
    const double cx = frame.Px(x), cy = frame.Py(y);
    if (s.style == SvgSeries::Style::kPoints)
      out << "<circle cx=\"" << Num(cx) << "\" cy=\"" << Num(cy) << "\" r=\"" << r << "\"/>";
    else
      out << "<path d=\"M" << Num(cx - r) << " " << Num(cy - r) << "L" << Num(cx + r) << " "
          << Num(cy + r) << "M" << Num(cx - r) << " " << Num(cy + r) << "L" << Num(cx + r)
          << " " << Num(cy - r) << "\"/>";
  }
  out << "</g>\n";
}

// The legend right of the plot area: bars, named series, legend-only entries.
void WriteLegend(const SvgFigure& f, const Frame& frame, std::ostringstream& out) {
  out << "<g class=\"legend\" transform=\"translate(" << Num(frame.area_x + frame.area_w + 14) << ","
      << Num(frame.area_y + 4) << ")\">";
  double y = 0;
  auto entry = [&](const std::string& name, const std::string& mark) {
    out << "<g transform=\"translate(0," << Num(y) << ")\">" << mark << "<text x=\"30\" y=\"5\">"
        << EscapeXml(name) << "</text></g>";
    y += 20;
  };
  for (const SvgBars& b : f.bars)
    if (!b.name.empty())
      entry(b.name, "<rect x=\"2\" y=\"-5\" width=\"20\" height=\"10\" fill=\"" + b.colour + "\"/>");
  for (const SvgSeries& s : f.series) {
    if (s.name.empty()) continue;
    std::string mark;
    if (s.style == SvgSeries::Style::kLine)
      mark = "<line x1=\"0\" x2=\"24\" y1=\"0\" y2=\"0\" stroke=\"" + s.colour + "\" stroke-width=\"" +
             Num(std::max(2.0, s.width)) + "\"" + (s.dashed ? " stroke-dasharray=\"6 4\"" : "") + "/>";
    else if (s.style == SvgSeries::Style::kPoints)
      mark = "<circle cx=\"12\" cy=\"0\" r=\"4\" fill=\"" + s.colour + "\"/>";
    else
      mark = "<path d=\"M8 -4L16 4M8 4L16 -4\" stroke=\"" + s.colour + "\" stroke-width=\"2\"/>";
    entry(s.name, mark);
  }
  for (const auto& [name, colour] : f.legend_only)
    entry(name, "<rect x=\"2\" y=\"-6\" width=\"20\" height=\"12\" fill=\"" + colour + "\"/>");
  out << "</g>\n";
}

}  // namespace

std::string EscapeXml(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '&': out += "&amp;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string SeriesColour(size_t i) {
  static const char* kPalette[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd",
                                   "#ff7f0e", "#8c564b", "#17becf", "#e377c2"};
  return kPalette[i % 8];
}

std::string RenderSvg(const SvgFigure& f) {
  const Frame frame = FitFrame(f);
  std::ostringstream out;
  // Inline SVGs share the page's id space: one clip id per figure.
  const std::string clip =
      "clip" + std::to_string(std::hash<std::string>{}(f.title + "|" + f.x_label + "|" + f.y_label) % 1000000007);
  WriteAxes(f, frame, clip, out);
  out << "<g class=\"data\" clip-path=\"url(#" << clip << ")\">\n";
  WriteImageAndBars(f, frame, out);
  for (const SvgSeries& s : f.series) WriteSeries(s, frame, out);
  out << "</g>\n";
  out << "<rect class=\"plot-area\" x=\"" << Num(frame.area_x) << "\" y=\"" << Num(frame.area_y)
      << "\" width=\"" << Num(frame.area_w) << "\" height=\"" << Num(frame.area_h)
      << "\" fill=\"none\" stroke=\"#555\"/>\n";
  if (frame.has_legend) WriteLegend(f, frame, out);
  out << "</svg>\n";
  return out.str();
}

}  // namespace graphslam::tools::job
