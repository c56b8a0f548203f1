#include "tools/job/report_html.h"

#include <cstdio>
#include <sstream>

namespace graphslam::tools::job {
namespace {

std::string Escape(const std::string& text) {
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

std::string Cell(const nlohmann::json& value) {
  if (value.is_null()) return "&ndash;";
  if (value.is_string()) return Escape(value.get<std::string>());
  if (value.is_number_float()) {
    char text[32];
    std::snprintf(text, sizeof(text), "%.6g", value.get<double>());
    return text;
  }
  return Escape(value.dump());
}

// A table of the array of objects `rows` with the given columns.
std::string Table(const nlohmann::json& rows, const std::vector<std::string>& columns) {
  std::ostringstream out;
  out << "<table><tr>";
  for (const std::string& c : columns) out << "<th>" << Escape(c) << "</th>";
  out << "</tr>\n";
  for (const nlohmann::json& row : rows) {
    out << "<tr>";
    for (const std::string& c : columns)
      out << "<td>" << (row.contains(c) ? Cell(row[c]) : "&ndash;") << "</td>";
    out << "</tr>\n";
  }
  out << "</table>\n";
  return out.str();
}

}  // namespace

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

std::string RenderReportHtml(const nlohmann::json& report,
                             const std::vector<std::pair<std::string, std::string>>& images) {
  std::ostringstream out;
  out << "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>graphslam job report</title>\n"
         "<style>body{font-family:sans-serif;margin:2em;max-width:1000px}"
         "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;"
         "text-align:right}th{background:#eee}.warn{color:#b00}img{max-width:100%}</style>"
         "</head><body>\n";
  out << "<h1>graphslam job report</h1>\n<p>Job <code>" << Escape(report.value("job", ""))
      << "</code>, output <code>" << Escape(report.value("output", "")) << "</code>, "
      << Cell(report.value("threads", nlohmann::json())) << " thread(s)";
  if (report.contains("memory_limit_bytes") && report["memory_limit_bytes"].get<int64_t>() > 0)
    out << ", memory limit " << report["memory_limit_bytes"].get<int64_t>() / (1024 * 1024) << " MiB";
  out << ".</p>\n";
  if (report.contains("warnings") && !report["warnings"].empty()) {
    out << "<h2>Warnings</h2><ul>";
    for (const nlohmann::json& w : report["warnings"]) out << "<li class=\"warn\">" << Cell(w) << "</li>";
    out << "</ul>\n";
  }
  out << "<h2>Runs</h2>\n"
      << Table(report["runs"], {"name", "poses", "component", "gps_fixes", "tied",
                                "position_rmse_m", "heading_rmse_rad", "joint_position_rmse_m",
                                "joint_heading_rmse_rad", "indoor_position_rmse_m",
                                "unknown_barcodes_skipped"});
  if (report.contains("robot_sightings"))
    out << "<h2>Robot-to-robot constraints per pair of runs</h2>\n"
        << Table(report["robot_sightings"]["pairs"], {"runs", "constraints"});
  out << "<h2>Components (solved independently)</h2>\n"
      << Table(report["components"], {"component", "runs", "poses", "features", "gps_fixes",
                                      "iterations", "initial_chi2", "final_chi2", "termination"});
  if (report.contains("gps_comparison")) {
    const nlohmann::json& c = report["gps_comparison"];
    out << "<h2>GPS and the indoor error (paper Figure 6)</h2>\n<p>Trajectory error against "
           "ground truth on the poses without GPS reception (indoors), after rigid alignment, "
           "with the GPS fixes of the outdoor poses and without any GPS:</p>\n"
        << Table(nlohmann::json::array({c}),
                 {"indoor_poses", "indoor_rmse_with_gps_m", "indoor_rmse_without_gps_m",
                  "position_rmse_with_gps_m", "position_rmse_without_gps_m"});
  }
  if (report.contains("map")) {
    out << "<h2>3-D map (scans fused at the optimized poses)</h2>\n<p>Files: ";
    for (const nlohmann::json& f : report["map"].value("files", nlohmann::json::array()))
      out << "<code>" << Cell(f) << "</code> ";
    out << "</p>\n"
        << Table(report["map"].contains("maps") ? report["map"]["maps"]
                                                : nlohmann::json::array({report["map"]}),
                 {"component", "runs", "scans", "points", "occupied_leaves", "free_leaves",
                  "pcd_points", "resolution_m", "max_range_m", "tiles", "fusion_seconds"});
  }
  out << "<h2>Stages</h2>\n" << Table(report["stages"], {"stage", "seconds", "peak_rss_bytes", "note"});
  for (const auto& [caption, png] : images) {
    out << "<h2>" << Escape(caption) << "</h2>\n<img alt=\"" << Escape(caption)
        << "\" src=\"data:image/png;base64," << Base64(png) << "\">\n";
  }
  out << "<h2>report.json</h2>\n<pre>" << Escape(report.dump(2)) << "</pre>\n</body></html>\n";
  return out.str();
}

}  // namespace graphslam::tools::job
