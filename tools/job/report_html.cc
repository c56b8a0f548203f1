#include "tools/job/report_html.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <sstream>

#include "tools/job/map_image.h"
#include "tools/job/report_figures.h"
#include "tools/job/svg_figure.h"
#include "tools/trajectory_statistics.h"

namespace graphslam::tools::job {
namespace {

using nlohmann::json;

constexpr double kDegreesPerRadian = 180.0 / 3.14159265358979323846;

const char kStyle[] =
    "*{box-sizing:border-box}"
    "body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;margin:0;color:#1d2228;"
    "background:#f3f4f6;line-height:1.4}"
    "main{max-width:1560px;margin:0 auto;padding:12px 20px 40px}"
    "h1{font-size:1.6em;margin:.4em 0}h2{font-size:1.25em;margin:.2em 0 .5em}"
    "h3{font-size:1.05em;margin:.8em 0 .4em}"
    "section{background:#fff;border:1px solid #d9dce1;border-radius:8px;padding:12px 18px;"
    "margin:14px 0;min-width:0}"
    ".meta{color:#555}.note{color:#555;font-size:.92em;margin:.3em 0}"
    ".warn{color:#a40000}"
    ".cards{display:flex;flex-wrap:wrap;gap:10px}"
    ".card{border:1px solid #d9dce1;border-radius:6px;padding:6px 14px;min-width:130px;"
    "background:#fafbfc}.card b{display:block;font-size:1.3em}.card span{color:#555;font-size:.85em}"
    ".table-wrap{overflow-x:auto;max-width:100%;margin:.4em 0}"
    "table{border-collapse:collapse;font-variant-numeric:tabular-nums;font-size:.93em}"
    "th,td{padding:4px 10px;border-bottom:1px solid #e3e5e8;text-align:right;white-space:nowrap}"
    "th{background:#eef0f3;font-weight:600;text-align:center;white-space:normal;"
    "vertical-align:bottom;min-width:4.5em}"
    "th.text,td.text{text-align:left}"
    "td.wrap{white-space:normal;min-width:12em}"
    ".bar{display:inline-block;height:.8em;background:#1f77b4;vertical-align:middle;"
    "margin-right:6px;border-radius:2px}"
    ".grid{display:grid;grid-template-columns:repeat(auto-fit,minmax(420px,1fr));gap:14px;"
    "align-items:start}"
    ".grid>*{min-width:0}"
    ".grid.run{grid-template-columns:repeat(auto-fit,minmax(600px,1fr))}"
    ".grid.run figure{max-width:860px}"
    "figure{margin:0}figcaption{color:#555;font-size:.9em;margin-top:.2em}"
    "svg{display:block;max-width:100%;height:auto}"
    ".wide{max-width:1100px}"
    "details pre{white-space:pre-wrap;word-break:break-all;font-size:.8em;background:#f7f7f7;"
    "padding:8px;max-height:40em;overflow:auto}"
    "code{word-break:break-all}"
    "@media (max-width:1280px){main{padding:8px 10px 30px}section{padding:10px 12px}"
    "th,td{padding:3px 6px}table{font-size:.88em}}";

std::string Escape(const std::string& text) { return EscapeXml(text); }

std::string FullValue(double v) {
  char text[40];
  std::snprintf(text, sizeof(text), "%.17g", v);
  return text;
}

// A numeric cell: the human text, the full value in data-value.
std::string NumberCell(double v, const std::string& unit = "") {
  if (!std::isfinite(v)) return "<td>&ndash;</td>";
  return "<td data-value=\"" + FullValue(v) + "\">" + Significant(v) + (unit.empty() ? "" : " " + unit) +
         "</td>";
}
std::string CountCell(int64_t v) {
  return "<td data-value=\"" + std::to_string(v) + "\">" + Significant(static_cast<double>(v)) + "</td>";
}
std::string TextCell(const std::string& text) { return "<td class=\"text\">" + Escape(text) + "</td>"; }
// A text cell that may wrap (lists of runs or files).
std::string WrapCell(const std::string& text) {
  return "<td class=\"text wrap\">" + Escape(text) + "</td>";
}

double Get(const json& j, const char* key) {
  return j.is_object() && j.contains(key) && j[key].is_number() ? j[key].get<double>() : NAN;
}

std::string Names(const json& value) {
  if (value.is_string()) return value.get<std::string>();
  if (!value.is_array()) return value.is_null() ? "" : value.dump();
  std::string out;
  for (const json& v : value) out += (out.empty() ? "" : ", ") + Names(v);
  return out;
}

// <table class=...> with the header row; rows are appended by the caller.
std::string TableStart(const std::string& cls, const std::vector<std::string>& headers) {
  std::string out = "<div class=\"table-wrap\"><table class=\"" + cls + "\"><thead><tr>";
  for (size_t i = 0; i < headers.size(); ++i)
    out += std::string(i == 0 ? "<th class=\"text\">" : "<th>") + headers[i] + "</th>";
  return out + "</tr></thead><tbody>\n";
}
const char kTableEnd[] = "</tbody></table></div>\n";

std::string Card(const std::string& value, const std::string& label) {
  return "<div class=\"card\"><b>" + value + "</b><span>" + Escape(label) + "</span></div>";
}

std::string StatsRow(const std::string& label, const ErrorStatistics& s, double scale,
                     const std::string& unit) {
  std::string row = "<tr>" + TextCell(label);
  for (double v : {s.rmse, s.mean, s.median, s.std, s.max}) row += NumberCell(v * scale, unit);
  return row + CountCell(s.count) + "</tr>\n";
}

const std::vector<std::string> kStatsHeaders = {"", "RMSE", "mean", "median", "std", "max", "pairs"};

void Summary(const json& report, const ReportInputs& inputs, std::ostringstream& out) {
  double seconds = 0, peak = 0;
  for (const json& s : report.value("stages", json::array())) {
    if (std::isfinite(Get(s, "seconds"))) seconds += Get(s, "seconds");
    if (std::isfinite(Get(s, "peak_rss_bytes"))) peak = std::max(peak, Get(s, "peak_rss_bytes"));
  }
  int64_t poses = 0;
  for (const ReportRun& r : inputs.runs) poses += static_cast<int64_t>(r.estimated.size());
  out << "<section id=\"summary\"><div class=\"cards\">"
      << Card(std::to_string(inputs.runs.size()), "runs")
      << Card(Significant(static_cast<double>(poses)), "poses")
      << Card(Significant(static_cast<double>(inputs.features.size())), "landmarks")
      << Card(std::to_string(report.value("components", json::array()).size()), "components solved")
      << Card(HumanSeconds(seconds), "total wall time")
      << Card(HumanBytes(static_cast<int64_t>(peak)), "peak memory");
  if (std::isfinite(Get(report, "position_rmse_m")))
    out << Card(Significant(Get(report, "position_rmse_m")) + " m", "ATE RMSE, all runs");
  out << "</div>\n";
  if (report.contains("warnings") && !report["warnings"].empty()) {
    out << "<h3>Warnings</h3><ul>";
    for (const json& w : report["warnings"]) out << "<li class=\"warn\">" << Escape(Names(w)) << "</li>";
    out << "</ul>\n";
  }
  out << "</section>\n";
}

Status MapSection(const json& report, const ReportInputs& inputs, std::ostringstream& out) {
  out << "<section id=\"map\"><h2>Map</h2>\n";
  if (inputs.map_pcds.empty()) {
    out << "<p class=\"note\">This job built no point cloud (no scans), so there is "
           "no picture of the 3-D map; the trajectory figure below shows the landmark map.</p>";
  } else {
    // A pixel no smaller than the map's voxels: finer pixels leave gaps.
    const double resolution = report.contains("map") ? Get(report["map"], "resolution_m") : NAN;
    StatusOr<MapRaster> raster =
        RenderMapRaster(inputs.map_pcds, 900, std::isfinite(resolution) ? resolution : 0.0);
    if (!raster.ok()) return raster.status();
    if (raster->png.empty()) {
      out << "<p class=\"note\">The map's point cloud is empty.</p>";
    } else {
      out << "<figure class=\"map-image wide\">" << MapFigure(*raster, inputs.runs)
          << "<figcaption>The fused point cloud seen from above: each pixel in the colour of the run "
             "with most points there, darker where more points are stacked (walls).</figcaption>"
             "</figure>\n";
    }
  }
  if (report.contains("map")) {
    const json& m = report["map"];
    out << "<h3>Map files</h3>" << TableStart("map-table", {"Map", "Runs", "Scans", "Points fused",
                                                             "Occupied cells", "Free cells",
                                                             "Points in .pcd", "Resolution",
                                                             "Max range", "Fusion time"});
    const json maps = m.contains("maps") ? m["maps"] : json::array({m});
    for (const json& e : maps) {
      out << "<tr>" << WrapCell(Names(e.value("files", m.value("files", json::array()))))
          << WrapCell(Names(e.value("runs", json()))) << NumberCell(Get(e, "scans"))
          << NumberCell(Get(e, "points")) << NumberCell(Get(e, "occupied_leaves"))
          << NumberCell(Get(e, "free_leaves")) << NumberCell(Get(e, "pcd_points"))
          << NumberCell(Get(e, "resolution_m"), "m") << NumberCell(Get(e, "max_range_m"), "m")
          << "<td>" << (std::isfinite(Get(e, "fusion_seconds")) ? HumanSeconds(Get(e, "fusion_seconds"))
                                                               : "&ndash;")
          << "</td></tr>\n";
    }
    out << kTableEnd;
  }
  out << "</section>\n";
  return Status::Ok();
}

void RunsTable(const json& report, std::ostringstream& out) {
  out << "<h3>Runs</h3>"
      << TableStart("runs", {"Run", "Poses", "Component", "GPS fixes", "Tied to others",
                             "ATE RMSE (own alignment)", "ATE RMSE (joint alignment)",
                             "Heading RMSE", "Indoor ATE RMSE"});
  for (const json& r : report.value("runs", json::array())) {
    out << "<tr>" << TextCell(r.value("name", "")) << NumberCell(Get(r, "poses"))
        << NumberCell(Get(r, "component")) << NumberCell(Get(r, "gps_fixes"))
        << "<td>" << (r.value("tied", false) ? "yes" : "no") << "</td>"
        << NumberCell(Get(r, "position_rmse_m"), "m") << NumberCell(Get(r, "joint_position_rmse_m"), "m")
        << NumberCell(Get(r, "heading_rmse_rad") * kDegreesPerRadian, "&deg;")
        << NumberCell(Get(r, "indoor_position_rmse_m"), "m") << "</tr>\n";
  }
  out << kTableEnd;
  // solver.repair_information: how many matrices each run had repaired.
  for (const json& r : report.value("runs", json::array())) {
    if (!r.contains("information_repairs")) continue;
    std::string lines;
    for (const json& line : r.value("information_repair_lines", json::array()))
      lines += (lines.empty() ? "" : ", ") + std::to_string(line.get<int64_t>());
    out << "<p class=\"note\">Run " << Escape(r.value("name", "")) << ": "
        << r["information_repairs"].get<int64_t>()
        << " information matrices were not positive definite and were repaired (first lines: "
        << lines << ").</p>\n";
  }
}

void AccuracySection(const json& report, const ReportInputs& inputs,
                     std::vector<std::optional<Eigen::Isometry2d>>* alignment,
                     std::ostringstream& out) {
  out << "<section id=\"accuracy\"><h2>Accuracy against ground truth</h2>\n"
         "<p class=\"note\">ATE: absolute position error after the rigid alignment of the run onto its "
         "ground truth (Umeyama). RPE: error of the relative motion over 1 m and 10 m of travelled "
         "ground-truth distance, no alignment needed.</p>\n";
  RunsTable(report, out);
  bool any = false;
  for (size_t r = 0; r < inputs.runs.size(); ++r) {
    const ReportRun& run = inputs.runs[r];
    alignment->push_back(std::nullopt);
    if (run.ground_truth.empty() || run.estimated.empty()) continue;
    StatusOr<TrajectoryErrors> matching = CompareTrajectories(run.estimated, run.ground_truth);
    if (!matching.ok()) {
      out << "<p class=\"warn\">" << Escape(run.name) << ": " << Escape(matching.status().message())
          << "</p>";
      continue;
    }
    any = true;
    alignment->back() = matching->alignment;
    const AbsoluteErrors ate = AbsolutePositionErrors(run.estimated, run.ground_truth, *matching);
    out << "<div class=\"run-accuracy\" data-run=\"" << Escape(run.name) << "\"><h3>Run "
        << Escape(run.name) << "</h3><div class=\"grid run\"><div>"
        << TableStart("ate", kStatsHeaders)
        << StatsRow("ATE position [m]", ate.statistics, 1.0, "") << kTableEnd
        << TableStart("rpe", kStatsHeaders);
    for (double delta : {1.0, 10.0}) {
      const RelativeErrors rpe = RelativePoseErrors(run.estimated, run.ground_truth, *matching, delta);
      const std::string over = Significant(delta) + " m";
      out << StatsRow("RPE translation over " + over + " [m]", rpe.translation, 1.0, "")
          << StatsRow("RPE rotation over " + over + " [°]", rpe.rotation, kDegreesPerRadian, "");
    }
    out << kTableEnd << "<p class=\"note\">" << matching->matched << " of " << run.estimated.size()
        << " poses matched to ground truth in time.</p></div>"
        << "<figure class=\"error-over-time\">" << ErrorOverTimeFigure(run.name, SeriesColour(r), ate)
        << "</figure></div></div>\n";
  }
  if (!any) out << "<p class=\"note\">No run of this job has ground truth.</p>\n";
  if (report.contains("gps_comparison")) {
    const json& c = report["gps_comparison"];
    out << "<h3>GPS and the indoor error</h3><p class=\"note\">ATE RMSE on the poses without GPS "
           "reception (indoors) and on all poses, solved with the outdoor GPS fixes and without any "
           "GPS.</p>"
        << TableStart("gps-comparison", {"", "with GPS", "without GPS"}) << "<tr>"
        << "<td class=\"text\">indoor poses (" << Significant(Get(c, "indoor_poses")) << ")</td>"
        << NumberCell(Get(c, "indoor_rmse_with_gps_m"), "m")
        << NumberCell(Get(c, "indoor_rmse_without_gps_m"), "m") << "</tr><tr>" << TextCell("all poses")
        << NumberCell(Get(c, "position_rmse_with_gps_m"), "m")
        << NumberCell(Get(c, "position_rmse_without_gps_m"), "m") << "</tr>" << kTableEnd;
  }
  if (report.contains("robot_sightings")) {
    out << "<h3>Robot-to-robot constraints per pair of runs</h3>"
        << TableStart("robot-sightings", {"Runs", "Constraints"});
    for (const json& p : report["robot_sightings"].value("pairs", json::array()))
      out << "<tr>" << WrapCell(Names(p.value("runs", json()))) << NumberCell(Get(p, "constraints"))
          << "</tr>";
    out << kTableEnd;
  }
  out << "</section>\n";
}

void ResidualSection(const ReportInputs& inputs, std::ostringstream& out) {
  out << "<section id=\"residuals\"><h2>Residuals by constraint type</h2>\n<p class=\"note\">Per "
         "constraint s = e<sup>T</sup> W e at the optimum. With the noise the information matrices W "
         "claim, s follows the chi2 distribution with as many degrees of freedom as the residual has "
         "(red): a histogram far to its right means W is too confident or there are outliers, far "
         "to its left that W is too cautious.</p>\n"
      << TableStart("residual-table", {"Constraint type", "Constraints", "Degrees of freedom",
                                       "Mean chi2 (expected: dof)", "Median chi2",
                                       "Above the 95 % quantile (expected 5 %)"});
  for (const ConstraintChi2& c : inputs.residuals) {
    const ErrorStatistics s = Summarize(c.chi2);
    const double q95 = Chi2Quantile(0.95, c.dof);
    int64_t above = 0;
    for (double v : c.chi2) above += v > q95 ? 1 : 0;
    out << "<tr>" << TextCell(c.type) << CountCell(s.count) << CountCell(c.dof) << NumberCell(s.mean)
        << NumberCell(s.median)
        << NumberCell(100.0 * static_cast<double>(above) / static_cast<double>(std::max<int64_t>(1, s.count)),
                      "%")
        << "</tr>\n";
  }
  out << kTableEnd << "<div class=\"grid\">";
  for (const ConstraintChi2& c : inputs.residuals) {
    int64_t beyond = 0;
    const std::string svg = ResidualHistogram(c, &beyond);
    out << "<figure class=\"residual-histogram\" data-type=\"" << Escape(c.type) << "\">" << svg
        << "<figcaption>" << Escape(c.type) << ": " << c.chi2.size() << " constraints";
    if (beyond > 0) out << ", " << beyond << " beyond the plotted range";
    out << ".</figcaption></figure>\n";
  }
  out << "</div></section>\n";
}

void ConvergenceSection(const json& report, std::ostringstream& out) {
  const json components = report.value("components", json::array());
  int64_t rejected = 0;
  for (const json& c : components)
    for (const json& h : c.value("history", json::array())) rejected += h.value("accepted", true) ? 0 : 1;
  out << "<section id=\"convergence\"><h2>Convergence</h2>\n<p class=\"note\">Levenberg-Marquardt: "
      << rejected << " rejected step(s) (red crosses), each followed by more damping.</p>\n"
      << "<div class=\"grid run\"><figure class=\"convergence-plot\">" << ConvergenceFigure(components)
      << "</figure><figure class=\"damping-plot\">" << DampingFigure(components) << "</figure></div>\n"
      << TableStart("components", {"Component", "Runs", "Poses", "Landmarks", "GPS fixes",
                                   "Iterations", "Initial chi2", "Final chi2", "Termination",
                                   "Linear solver"});
  for (const json& c : components)
    out << "<tr>" << TextCell(std::to_string(c.value("component", 0)))
        << WrapCell(Names(c.value("runs", json()))) << NumberCell(Get(c, "poses"))
        << NumberCell(Get(c, "features")) << NumberCell(Get(c, "gps_fixes"))
        << NumberCell(Get(c, "iterations")) << NumberCell(Get(c, "initial_chi2"))
        << NumberCell(Get(c, "final_chi2")) << TextCell(c.value("termination", ""))
        << TextCell(c.value("linear_solver", "")) << "</tr>\n";
  out << kTableEnd << "</section>\n";
}

void StagesSection(const json& report, std::ostringstream& out) {
  const json stages = report.value("stages", json::array());
  double longest = 1e-9;
  for (const json& s : stages)
    if (std::isfinite(Get(s, "seconds"))) longest = std::max(longest, Get(s, "seconds"));
  out << "<section id=\"stages\"><h2>Time and memory per stage</h2>\n"
      << TableStart("stages", {"Stage", "Wall time", "Peak memory (resident, at the stage's end)",
                               "Note"});
  for (const json& s : stages) {
    const double seconds = Get(s, "seconds");
    const double width = std::isfinite(seconds) ? 160.0 * seconds / longest : 0.0;
    char bar[96];
    std::snprintf(bar, sizeof(bar), "<span class=\"bar\" style=\"width:%.0fpx\"></span>", width);
    out << "<tr>" << TextCell(s.value("stage", "")) << "<td class=\"text\" data-value=\""
        << FullValue(seconds) << "\">" << bar << HumanSeconds(seconds) << "</td><td data-value=\""
        << FullValue(Get(s, "peak_rss_bytes")) << "\">"
        << HumanBytes(static_cast<int64_t>(std::isfinite(Get(s, "peak_rss_bytes")) ? Get(s, "peak_rss_bytes") : 0))
        << "</td>" << TextCell(s.value("note", "")) << "</tr>\n";
  }
  out << kTableEnd << "</section>\n";
}

}  // namespace

std::string Significant(double value) {
  if (!std::isfinite(value)) return "&ndash;";
  const double magnitude = std::abs(value);
  char text[48];
  if (magnitude >= 1e9) {
    std::snprintf(text, sizeof(text), "%.3g", value);
    return text;
  }
  if (magnitude >= 1000) {
    std::snprintf(text, sizeof(text), "%.0f", std::round(value));
    std::string digits = text, out;
    const size_t sign = digits[0] == '-' ? 1 : 0;
    for (size_t i = 0; i < digits.size(); ++i) {
      if (i > sign && (digits.size() - i) % 3 == 0) out += "&#8201;";  // thin space
      out += digits[i];
    }
    return out;
  }
  std::snprintf(text, sizeof(text), "%.3g", value);
  return text;
}

std::string HumanSeconds(double seconds) {
  if (!std::isfinite(seconds)) return "&ndash;";
  char text[48];
  if (seconds < 60) {
    std::snprintf(text, sizeof(text), "%.3g s", seconds);
  } else if (seconds < 3600) {
    const auto s = static_cast<int64_t>(std::lround(seconds));
    std::snprintf(text, sizeof(text), "%lld min %02lld s", static_cast<long long>(s / 60),
                  static_cast<long long>(s % 60));
  } else {
    const auto m = static_cast<int64_t>(std::lround(seconds / 60));
    std::snprintf(text, sizeof(text), "%lld h %02lld min", static_cast<long long>(m / 60),
                  static_cast<long long>(m % 60));
  }
  return text;
}

std::string HumanBytes(int64_t bytes) {
  char text[48];
  const double b = static_cast<double>(bytes);
  if (b < 1024.0 * 1024.0)
    std::snprintf(text, sizeof(text), "%.3g KiB", b / 1024.0);
  else if (b < 1024.0 * 1024.0 * 1024.0)
    std::snprintf(text, sizeof(text), "%.3g MiB", b / (1024.0 * 1024.0));
  else
    std::snprintf(text, sizeof(text), "%.3g GiB", b / (1024.0 * 1024.0 * 1024.0));
  return text;
}

std::string Base64(const std::string& bytes) {
  static const char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t v = (static_cast<uint8_t>(bytes[i]) << 16) |
                       (static_cast<uint8_t>(bytes[i + 1]) << 8) | static_cast<uint8_t>(bytes[i + 2]);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const uint32_t v = static_cast<uint8_t>(bytes[i]) << 16;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const uint32_t v = (static_cast<uint8_t>(bytes[i]) << 16) | (static_cast<uint8_t>(bytes[i + 1]) << 8);
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

StatusOr<std::string> RenderReportHtml(const json& report, const ReportInputs& inputs) {
  std::ostringstream out;
  out << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
         "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">"
         "<title>graphslam job report</title>\n<style>"
      << kStyle << "</style></head><body><main>\n";
  out << "<h1>graphslam job report</h1>\n<p class=\"meta\">Job <code>"
      << Escape(report.value("job", "")) << "</code>, output <code>" << Escape(report.value("output", ""))
      << "</code>, " << Significant(Get(report, "threads")) << " thread(s)";
  if (Get(report, "memory_limit_bytes") > 0)
    out << ", memory limit " << HumanBytes(static_cast<int64_t>(Get(report, "memory_limit_bytes")));
  out << ".</p>\n";
  Summary(report, inputs, out);
  GS_RETURN_IF_ERROR(MapSection(report, inputs, out));
  // Accuracy first (it computes each run's alignment), shown after the
  // trajectory figure that needs it.
  std::ostringstream accuracy;
  std::vector<std::optional<Eigen::Isometry2d>> alignment;
  AccuracySection(report, inputs, &alignment, accuracy);
  out << "<section id=\"trajectories\"><h2>Trajectories</h2><figure class=\"trajectories wide\">"
      << TrajectoryFigure(inputs, alignment)
      << "<figcaption>Each run's optimized trajectory in its colour; ground truth (black, dashed) "
         "drawn on top after the run's alignment.</figcaption></figure></section>\n"
      << accuracy.str();
  ResidualSection(inputs, out);
  ConvergenceSection(report, out);
  StagesSection(report, out);
  if (report.contains("association")) {
    out << "<section id=\"association\"><h2>Data association</h2><details><summary>as recorded"
           "</summary><pre>"
        << Escape(report["association"].dump(2)) << "</pre></details></section>\n";
  }
  out << "<section id=\"raw\"><h2>report.json</h2><details><summary>Everything above as data "
         "(report.json beside this page)</summary><pre>"
      << Escape(report.dump(2)) << "</pre></details></section>\n</main></body></html>\n";
  return out.str();
}

}  // namespace graphslam::tools::job
