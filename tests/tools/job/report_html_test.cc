// report.html: its building blocks (base64, human units, SVG figures, PNG,
// per-constraint chi2) and, end to end, the report of a small simulated job
// with scans and GPS: every section, table and figure is there, the legend
// lies outside the plot area, ground truth is drawn over the estimates, and
// the ATE / RPE numbers are those of tools/trajectory_statistics.h computed
// here from the job's TUM files and the simulator's ground truth.
#include "tools/job/report_html.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <regex>

#include "core/se2.h"
#include "tests/tools/job/job_test_folder.h"
#include "tools/campus_simulator.h"
#include "tools/job/constraint_residuals.h"
#include "tools/job/map_image.h"
#include "tools/job/report_figures.h"
#include "tools/job/svg_figure.h"
#include "tools/trajectory_statistics.h"

namespace graphslam::tools::job {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

// The text between the first `open` at or after `from` and the next `close`.
std::string Between(const std::string& text, const std::string& open, const std::string& close,
                    size_t from = 0) {
  const size_t a = text.find(open, from);
  if (a == std::string::npos) return "";
  const size_t b = text.find(close, a);
  return text.substr(a, b == std::string::npos ? std::string::npos : b + close.size() - a);
}

TEST(Base64, Rfc4648TestVectors) {
  EXPECT_EQ(Base64(""), "");
  EXPECT_EQ(Base64("f"), "Zg==");
  EXPECT_EQ(Base64("fo"), "Zm8=");
  EXPECT_EQ(Base64("foo"), "Zm9v");
  EXPECT_EQ(Base64("foob"), "Zm9vYg==");
  EXPECT_EQ(Base64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(Base64("foobar"), "Zm9vYmFy");
  EXPECT_EQ(Base64(std::string("\xff\xfe\x00", 3)), "//4A");
}

TEST(HumanUnits, ThreeSignificantDigits) {
  EXPECT_EQ(Significant(0.0123456), "0.0123");
  EXPECT_EQ(Significant(1.23456), "1.23");
  EXPECT_EQ(Significant(123.456), "123");
  EXPECT_EQ(Significant(44040192), "44&#8201;040&#8201;192");
  EXPECT_EQ(Significant(NAN), "&ndash;");
  EXPECT_EQ(HumanSeconds(1.2345678), "1.23 s");
  EXPECT_EQ(HumanSeconds(0.00412), "0.00412 s");
  EXPECT_EQ(HumanSeconds(125.4), "2 min 05 s");
  EXPECT_EQ(HumanSeconds(3720), "1 h 02 min");
  EXPECT_EQ(HumanBytes(44040192), "42 MiB");
  EXPECT_EQ(HumanBytes(512 * 1024), "512 KiB");
  EXPECT_EQ(HumanBytes(int64_t{3} << 29), "1.5 GiB");
}

// The numbers of `<tag ... name="...">` attributes.
double Attribute(const std::string& element, const std::string& name) {
  std::smatch m;
  EXPECT_TRUE(std::regex_search(element, m, std::regex(" " + name + "=\"([-0-9.e]+)\"")))
      << name << " in " << element.substr(0, 200);
  return m.empty() ? NAN : std::stod(m[1]);
}

struct Box {
  double x = NAN, y = NAN, width = NAN, height = NAN;
};

Box PlotArea(const std::string& svg) {
  std::smatch m;
  Box box;
  if (!std::regex_search(svg, m, std::regex("<rect class=\"plot-area\"[^>]*>"))) return box;
  const std::string rect = m[0];
  return {Attribute(rect, "x"), Attribute(rect, "y"), Attribute(rect, "width"),
          Attribute(rect, "height")};
}

// (x, y) of the legend's translate(), NaN if there is no legend.
std::pair<double, double> LegendPosition(const std::string& svg) {
  std::smatch m;
  if (!std::regex_search(svg, m,
                         std::regex("<g class=\"legend\" transform=\"translate\\(([-0-9.]+),([-0-9.]+)\\)")))
    return {NAN, NAN};
  return {std::stod(m[1]), std::stod(m[2])};
}

TEST(SvgFigure, LegendOutsideThePlotAreaAndDataInOrder) {
  SvgFigure f;
  f.title = "t";
  f.series.push_back({"first", "#111111", SvgSeries::Style::kLine, 1, false, {0, 1, 2}, {0, 1, 4}});
  f.series.push_back({"second", "#222222", SvgSeries::Style::kPoints, 2, false, {0, 2}, {1, 3}});
  const std::string svg = RenderSvg(f);
  const Box area = PlotArea(svg);
  const auto [lx, ly] = LegendPosition(svg);
  ASSERT_TRUE(std::isfinite(area.width));
  EXPECT_GT(lx, area.x + area.width);  // right of the plot area
  EXPECT_LT(lx, f.width);
  EXPECT_LT(svg.find("data-name=\"first\""), svg.find("data-name=\"second\""));
  EXPECT_THAT(svg, HasSubstr(">first</text>"));
  EXPECT_THAT(svg, HasSubstr(">second</text>"));
  // Without names, no legend and a wider plot area.
  f.series[0].name = f.series[1].name = "";
  const std::string bare = RenderSvg(f);
  EXPECT_THAT(bare, Not(HasSubstr("class=\"legend\"")));
  EXPECT_GT(PlotArea(bare).width, area.width);
}

TEST(SvgFigure, EqualAxesKeepTheScale) {
  SvgFigure f;
  f.equal_axes = true;
  f.series.push_back({"", "#000000", SvgSeries::Style::kLine, 1, false, {0, 100}, {0, 10}});
  f.series.push_back({"", "#000000", SvgSeries::Style::kPoints, 1, false, {0, 100}, {0, 10}});
  const std::string svg = RenderSvg(f);
  // The two points of the second series: dx / dy in pixels = 100 / 10.
  std::vector<std::pair<double, double>> points;
  const std::regex circle("<circle cx=\"([-0-9.]+)\" cy=\"([-0-9.]+)\"");
  for (std::sregex_iterator it(svg.begin(), svg.end(), circle), end; it != end; ++it)
    points.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]));
  ASSERT_EQ(points.size(), 2u);
  const double dx = points[1].first - points[0].first, dy = points[0].second - points[1].second;
  EXPECT_NEAR(dx / dy, 10.0, 0.2);  // 0.1 px rounding
}

// Log-log (the scaling benchmark's figures): points a decade apart on both
// axes are equally spaced, and x <= 0 is dropped.
TEST(SvgFigure, LogAxesSpaceDecadesEqually) {
  SvgFigure f;
  f.log_x = f.log_y = true;
  f.series.push_back(
      {"", "#000000", SvgSeries::Style::kPoints, 1, false, {0, 1e4, 1e5, 1e6}, {5, 1, 10, 100}});
  const std::string svg = RenderSvg(f);
  std::vector<std::pair<double, double>> points;
  const std::regex circle("<circle cx=\"([-0-9.]+)\" cy=\"([-0-9.]+)\"");
  for (std::sregex_iterator it(svg.begin(), svg.end(), circle), end; it != end; ++it)
    points.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]));
  ASSERT_EQ(points.size(), 3u);
  EXPECT_NEAR(points[1].first - points[0].first, points[2].first - points[1].first, 0.2);
  EXPECT_NEAR(points[0].second - points[1].second, points[1].second - points[2].second, 0.2);
  EXPECT_GT(points[0].second - points[1].second, 10.0);
}

// A log axis whose data stays inside one decade (a solve that converged in
// two iterations) still shows the decades around it.
TEST(SvgFigure, LogAxisWithinOneDecadeShowsTheDecadesAroundIt) {
  SvgFigure f;
  f.log_y = true;
  f.series.push_back({"", "#000000", SvgSeries::Style::kLine, 1, false, {0, 1}, {420, 390}});
  const std::string svg = RenderSvg(f);
  EXPECT_THAT(svg, HasSubstr(">1e2<"));
  EXPECT_THAT(svg, HasSubstr(">1e3<"));
  EXPECT_THAT(svg, Not(HasSubstr(">1e1<")));
  EXPECT_THAT(svg, Not(HasSubstr(">1e4<")));
}

TEST(EncodePng, InflatesToTheFilteredRows) {
  const std::vector<uint8_t> rgb = {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30};  // 2 x 2
  const std::string png = EncodePng(2, 2, rgb);
  ASSERT_GT(png.size(), 8u + 25 + 12);
  EXPECT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(png.substr(12, 4), "IHDR");
  EXPECT_EQ(png.substr(16, 8), std::string("\0\0\0\x02\0\0\0\x02", 8));
  const size_t idat = png.find("IDAT");
  ASSERT_NE(idat, std::string::npos);
  const auto* b = reinterpret_cast<const uint8_t*>(png.data() + idat - 4);
  const uint32_t length = (b[0] << 24) | (b[1] << 16) | (b[2] << 8) | b[3];
  std::vector<uint8_t> raw(2 * 7);
  uLongf size = raw.size();
  ASSERT_EQ(uncompress(raw.data(), &size, reinterpret_cast<const Bytef*>(png.data() + idat + 4), length),
            Z_OK);
  const std::vector<uint8_t> expected = {0, 255, 0, 0, 0, 255, 0, 0, 0, 0, 255, 10, 20, 30};
  EXPECT_EQ(raw, expected);
  // The chunk's CRC covers type and data.
  const auto* crc = reinterpret_cast<const uint8_t*>(png.data() + idat + 4 + length);
  EXPECT_EQ((uint32_t{crc[0]} << 24) | (crc[1] << 16) | (crc[2] << 8) | crc[3],
            crc32(0, reinterpret_cast<const Bytef*>(png.data() + idat), length + 4));
}

TEST(Chi2Density, IsTheChi2Distribution) {
  for (double s : {0.1, 1.0, 4.0}) EXPECT_NEAR(Chi2Density(s, 2), 0.5 * std::exp(-s / 2), 1e-12);
  EXPECT_NEAR(Chi2Density(1.0, 3), std::sqrt(1.0 / (2 * M_PI)) * std::exp(-0.5), 1e-12);
  for (int k : {2, 3}) {
    double mass = 0, mean = 0;
    for (double s = 0.0005; s < 80; s += 0.001) {
      mass += Chi2Density(s, k) * 0.001;
      mean += s * Chi2Density(s, k) * 0.001;
    }
    EXPECT_NEAR(mass, 1.0, 1e-3) << k;
    EXPECT_NEAR(mean, k, 1e-2) << k;
  }
}

TEST(ConstraintChi2ByType, HandComputed) {
  core::Problem2d p;
  p.poses = {core::Pose2(0, 0, 0), core::Pose2(1.2, 0, 0)};
  p.features = {core::Point2(3, 4), core::Point2(0, 9)};
  core::RelativePoseConstraint odometry;
  odometry.from = 0, odometry.to = 1;
  odometry.z = core::Pose2(1.0, 0, 0);  // off by 0.2 in x
  odometry.information = Eigen::Vector3d(100, 100, 1000).asDiagonal();
  p.relative_poses.push_back(odometry);
  core::Observation seen;  // range 5 measured 5.5 from pose 0
  seen.pose = 0, seen.feature = 0;
  seen.z = Eigen::Vector2d(5.5, std::atan2(4.0, 3.0));
  seen.information = Eigen::Vector2d(4, 100).asDiagonal();
  p.observations.push_back(seen);
  core::Observation dropped = seen;  // of an excluded feature
  dropped.feature = 1;
  p.observations.push_back(dropped);
  core::GpsConstraint gps;
  gps.pose = 1, gps.z = Eigen::Vector2d(1.2, 0.3), gps.information = Eigen::Matrix2d::Identity() * 4;
  p.gps.push_back(gps);
  const std::vector<ConstraintChi2> types = ConstraintChi2ByType(p, {0, 1});
  ASSERT_EQ(types.size(), 3u);
  EXPECT_EQ(types[0].dof, 3);
  ASSERT_EQ(types[0].chi2.size(), 1u);
  EXPECT_NEAR(types[0].chi2[0], 100 * 0.2 * 0.2, 1e-9);
  EXPECT_EQ(types[1].dof, 2);
  ASSERT_EQ(types[1].chi2.size(), 1u);  // the excluded feature's is left out
  EXPECT_NEAR(types[1].chi2[0], 4 * 0.5 * 0.5, 1e-9);
  EXPECT_EQ(types[2].type, "GPS");
  EXPECT_NEAR(types[2].chi2[0], 4 * 0.3 * 0.3, 1e-9);
}

TEST(ConvergenceFigure, MarksRejectedStepsAndDamping) {
  const nlohmann::json components = nlohmann::json::array(
      {{{"component", 0},
        {"initial_chi2", 1e6},
        {"history",
         {{{"iteration", 1}, {"chi2", 1e4}, {"lambda", 1e-4}, {"accepted", true}},
          {{"iteration", 2}, {"chi2", 1e4}, {"lambda", 1e-5}, {"accepted", false},
           {"candidate_chi2", 3e4}},
          {{"iteration", 3}, {"chi2", 1e2}, {"lambda", 2e-5}, {"accepted", true}}}}}});
  const std::string chi2 = ConvergenceFigure(components);
  const std::string rejected = Between(chi2, "data-name=\"rejected step (chi2 it led to)\"", "</g>");
  ASSERT_FALSE(rejected.empty());
  // One cross (two strokes in one path) for iteration 2.
  EXPECT_EQ(std::count(rejected.begin(), rejected.end(), 'M'), 2);
  EXPECT_THAT(chi2, HasSubstr(">1e6</text>"));  // log ticks at powers of ten
  EXPECT_THAT(chi2, HasSubstr(">1e2</text>"));
  const std::string damping = DampingFigure(components);
  EXPECT_THAT(damping, HasSubstr("data-name=\"rejected step\""));
  EXPECT_THAT(damping, HasSubstr(">1e-5</text>"));
  // Without rejections, no such legend entry.
  nlohmann::json accepted = components;
  accepted[0]["history"][1]["accepted"] = true;
  EXPECT_THAT(ConvergenceFigure(accepted), Not(HasSubstr("rejected")));
}

// ---- the report of a job ------------------------------------------------------

using ReportOfAJob = JobTestFolder;

// data-value of every cell in the row whose label cell starts with `label`.
std::vector<double> RowValues(const std::string& table, const std::string& label) {
  std::vector<double> values;
  const std::string row = Between(table, "<td class=\"text\">" + label, "</tr>");
  const std::regex value("data-value=\"([^\"]+)\"");
  for (std::sregex_iterator it(row.begin(), row.end(), value), end; it != end; ++it)
    values.push_back(std::stod((*it)[1]));
  return values;
}

void ExpectStatistics(const std::vector<double>& row, const ErrorStatistics& s, double scale,
                      const std::string& what) {
  ASSERT_EQ(row.size(), 6u) << what;
  const double expected[] = {s.rmse, s.mean, s.median, s.std, s.max};
  for (int i = 0; i < 5; ++i)
    EXPECT_NEAR(row[static_cast<size_t>(i)], expected[i] * scale, 1e-12 + 1e-9 * std::abs(expected[i]))
        << what << " column " << i;
  EXPECT_EQ(row[5], static_cast<double>(s.count)) << what;
  EXPECT_GT(s.count, 0) << what;
}

TEST_F(ReportOfAJob, ShowsEveryTableAndFigure) {
  const Status status =
      Run("output: out\n"
          "threads: 2\n"
          "compare_without_gps: true\n"
          "map: {resolution: 0.25, max_range: 25}\n"
          "runs:\n"
          "  - name: campus\n"
          "    format: simulate\n"
          "    simulate: {poses: 400, runs: 2, gps_every: 10, seed: 4, scans: true,\n"
          "               scan_beams: 40, scan_max_range: 25}\n");
  ASSERT_TRUE(status.ok()) << status.ToString();
  const std::filesystem::path out = dir_ / "out";
  const std::string html = ReadFile(out / "report.html");
  const nlohmann::json report = ReadJsonFile(out / "report.json");

  // Self-contained and script-free.
  EXPECT_THAT(html, Not(HasSubstr("http")));
  EXPECT_THAT(html, Not(HasSubstr("<script")));
  EXPECT_THAT(html, Not(HasSubstr("src=\"")));  // no external image either
  for (const char* id : {"summary", "map", "trajectories", "accuracy", "residuals", "convergence",
                         "stages"})
    EXPECT_THAT(html, HasSubstr("<section id=\"" + std::string(id) + "\"")) << id;

  // The map picture: a PNG raster with the runs in its legend, outside the plot.
  const std::string map = Between(html, "<figure class=\"map-image", "</figure>");
  ASSERT_FALSE(map.empty());
  EXPECT_THAT(map, HasSubstr("<image class=\"raster\""));
  EXPECT_THAT(map, HasSubstr("href=\"data:image/png;base64,iVBORw0KGgo"));  // the PNG signature
  EXPECT_THAT(map, HasSubstr(">campus_1</text>"));
  EXPECT_THAT(map, HasSubstr(">campus_2</text>"));
  EXPECT_GT(LegendPosition(map).first, PlotArea(map).x + PlotArea(map).width);

  // Trajectories: legend outside the plot area, ground truth after (over) the estimates.
  const std::string trajectories = Between(html, "<figure class=\"trajectories", "</figure>");
  ASSERT_FALSE(trajectories.empty());
  const Box area = PlotArea(trajectories);
  const auto [legend_x, legend_y] = LegendPosition(trajectories);
  EXPECT_GT(legend_x, area.x + area.width);
  EXPECT_GE(legend_y, area.y);
  for (const char* name : {"campus_1 (estimate)", "campus_2 (estimate)", "ground truth", "landmarks",
                           "GPS fixes"})
    EXPECT_THAT(trajectories, HasSubstr(">" + std::string(name) + "</text>")) << name;
  const size_t truth = trajectories.find("data-name=\"ground truth\"");
  ASSERT_NE(truth, std::string::npos);
  EXPECT_GT(truth, trajectories.find("data-name=\"campus_2 (estimate)\""));
  EXPECT_GT(truth, trajectories.find("data-name=\"landmarks\""));

  // Per run: ATE and RPE tables with the numbers of trajectory_statistics.h,
  // and the error over time.
  CampusSimulatorOptions options;
  options.poses = 400, options.runs = 2, options.gps_every = 10, options.seed = 4;
  StatusOr<SimulatedCampus> campus = SimulateCampus(options);
  ASSERT_TRUE(campus.ok());
  for (int run = 0; run < 2; ++run) {
    const std::string name = "campus_" + std::to_string(run + 1);
    // The exported ground truth is the simulator's, on the estimate's clock
    // (a synthetic run's times follow the previous run's: job_export.h).
    StatusOr<std::vector<StampedPose2>> exported_truth =
        ReadTum((out / "trajectories" / (name + "_groundtruth.tum")).string());
    ASSERT_TRUE(exported_truth.ok()) << exported_truth.status().ToString();
    std::vector<StampedPose2> truth_poses;
    for (size_t i = 0; i < campus->true_poses.size(); ++i)
      if (campus->run_of_pose[i] == run)
        truth_poses.push_back({campus->problem.pose_stamps[i], campus->true_poses[i]});
    ASSERT_EQ(exported_truth->size(), truth_poses.size());
    for (size_t i = 0; i < truth_poses.size(); ++i)
      EXPECT_LT((exported_truth->at(i).pose - truth_poses[i].pose).norm(), 1e-6) << name << " " << i;
    truth_poses = *exported_truth;
    StatusOr<std::vector<StampedPose2>> estimate = ReadTum((out / "trajectories" / (name + ".tum")).string());
    ASSERT_TRUE(estimate.ok()) << estimate.status().ToString();
    StatusOr<TrajectoryErrors> matching = CompareTrajectories(*estimate, truth_poses);
    ASSERT_TRUE(matching.ok());
    const std::string block = Between(html, "<div class=\"run-accuracy\" data-run=\"" + name + "\"",
                                      "</figure>");
    ASSERT_FALSE(block.empty()) << name;
    const std::string ate = Between(block, "<table class=\"ate\"", "</table>");
    const std::string rpe = Between(block, "<table class=\"rpe\"", "</table>");
    for (const char* header : {"RMSE", "mean", "median", "std", "max"}) {
      EXPECT_THAT(ate, HasSubstr("<th>" + std::string(header) + "</th>"));
      EXPECT_THAT(rpe, HasSubstr("<th>" + std::string(header) + "</th>"));
    }
    const AbsoluteErrors absolute = AbsolutePositionErrors(*estimate, truth_poses, *matching);
    ExpectStatistics(RowValues(ate, "ATE position"), absolute.statistics, 1.0, name + " ATE");
    EXPECT_NEAR(absolute.statistics.rmse, report["runs"][run]["position_rmse_m"].get<double>(), 1e-6);
    for (double delta : {1.0, 10.0}) {
      const RelativeErrors r = RelativePoseErrors(*estimate, truth_poses, *matching, delta);
      const std::string over = delta == 1.0 ? "1 m" : "10 m";
      ExpectStatistics(RowValues(rpe, "RPE translation over " + over), r.translation, 1.0,
                       name + " RPE t " + over);
      ExpectStatistics(RowValues(rpe, "RPE rotation over " + over), r.rotation, 180.0 / M_PI,
                       name + " RPE r " + over);
    }
    const std::string over_time = Between(block, "<figure class=\"error-over-time\"", "</figure>");
    EXPECT_THAT(over_time, HasSubstr("Position error over time: " + name));
    EXPECT_THAT(over_time, HasSubstr("<path class=\"series\""));
  }

  // Residual histograms with their chi2 density, one per constraint type.
  for (const auto& [type, dof] : std::vector<std::pair<std::string, int>>{
           {"velocity motion", 3}, {"landmark observation", 2}, {"GPS", 2}}) {
    const std::string figure =
        Between(html, "<figure class=\"residual-histogram\" data-type=\"" + type + "\"", "</figure>");
    ASSERT_FALSE(figure.empty()) << type;
    EXPECT_THAT(figure, HasSubstr("<g class=\"bars\""));
    EXPECT_THAT(figure, HasSubstr("data-name=\"chi2, " + std::to_string(dof) + " dof\""));
    EXPECT_GT(LegendPosition(figure).first, PlotArea(figure).x + PlotArea(figure).width);
  }

  // Convergence (log chi2) and damping, from the recorded history.
  const nlohmann::json& history = report["components"][0]["history"];
  ASSERT_FALSE(history.empty());
  EXPECT_TRUE(history[0].contains("lambda"));
  EXPECT_TRUE(history[0].contains("accepted"));
  const std::string convergence = Between(html, "<figure class=\"convergence-plot\"", "</figure>");
  EXPECT_THAT(convergence, HasSubstr("chi2 (log scale)"));
  EXPECT_THAT(convergence, HasSubstr("data-name=\"component 0\""));
  EXPECT_THAT(convergence, HasSubstr(">1e"));  // log ticks
  const std::string damping = Between(html, "<figure class=\"damping-plot\"", "</figure>");
  EXPECT_THAT(damping, HasSubstr("data-name=\"component 0\""));

  // Stages: human names and units.
  const std::string stages = Between(html, "<table class=\"stages\"", "</table>");
  EXPECT_THAT(stages, HasSubstr("Peak memory"));
  EXPECT_THAT(stages, HasSubstr(" MiB</td>"));
  EXPECT_THAT(stages, HasSubstr(" s</td>"));
  EXPECT_THAT(stages, Not(HasSubstr("peak_rss_bytes")));
  for (const char* stage : {"ingest", "optimize", "map", "export"})
    EXPECT_THAT(stages, HasSubstr("<td class=\"text\">" + std::string(stage) + "</td>"));
  // Runs as text, not JSON.
  const std::string components = Between(html, "<table class=\"components\"", "</table>");
  EXPECT_THAT(components, HasSubstr("campus_1, campus_2"));
  EXPECT_THAT(components, Not(HasSubstr("[\"")));
}

}  // namespace
}  // namespace graphslam::tools::job
