// The self-contained HTML report and the PLplot PNGs it embeds.
#include "tools/job/report_html.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "tools/job/plots.h"

namespace graphslam::tools::job {
namespace {

using ::testing::HasSubstr;

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

std::string Scratch() {
  return (std::filesystem::temp_directory_path() /
          ("graphslam_plot_" + std::to_string(getpid()) + ".png"))
      .string();
}

bool IsPng(const std::string& bytes) {
  return bytes.size() > 100 && bytes.compare(0, 8, "\x89PNG\r\n\x1a\n") == 0;
}

TEST(Plots, DrawPngs) {
  TrajectoryPlot plot;
  XySeries run{"run", {}, {}};
  for (int i = 0; i < 100; ++i) {
    run.x.push_back(10 * std::cos(i * 0.1));
    run.y.push_back(10 * std::sin(i * 0.1));
  }
  plot.estimated.push_back(run);
  plot.ground_truth.push_back(run);
  plot.gps = {"gps", {0, 5}, {1, 2}};
  plot.features = {"f", {3}, {4}};
  StatusOr<std::string> png = PlotTrajectories(plot, Scratch());
  ASSERT_TRUE(png.ok()) << png.status().ToString();
  EXPECT_TRUE(IsPng(*png));
  EXPECT_FALSE(std::filesystem::exists(Scratch()));  // the scratch file is removed

  StatusOr<std::string> curve = PlotConvergence({{"c0", {0, 1, 2}, {1e6, 1e3, 9e2}}}, Scratch());
  ASSERT_TRUE(curve.ok()) << curve.status().ToString();
  EXPECT_TRUE(IsPng(*curve));
  StatusOr<std::string> bars = PlotStages({{"ingest", 1.0, 10}, {"optimize", 3.0, 20}}, Scratch());
  ASSERT_TRUE(bars.ok()) << bars.status().ToString();
  EXPECT_TRUE(IsPng(*bars));
  // Different data, different pictures.
  StatusOr<std::string> other = PlotStages({{"ingest", 2.0, 10}}, Scratch());
  ASSERT_TRUE(other.ok());
  EXPECT_NE(*other, *bars);
}

TEST(ReportHtml, EmbedsImagesAndEscapesText) {
  nlohmann::json report;
  report["job"] = "a<b>.yaml";
  report["output"] = "out";
  report["threads"] = 2;
  report["warnings"] = {"run x is tied to no other run"};
  report["runs"] = nlohmann::json::array({{{"name", "r1"}, {"poses", 10}, {"position_rmse_m", 0.25}}});
  report["components"] = nlohmann::json::array();
  report["stages"] = nlohmann::json::array({{{"stage", "ingest"}, {"seconds", 1.5}}});
  const std::string html = RenderReportHtml(report, {{"Plot", "foobar"}});
  EXPECT_THAT(html, HasSubstr("<!DOCTYPE html>"));
  EXPECT_THAT(html, HasSubstr("src=\"data:image/png;base64,Zm9vYmFy\""));
  EXPECT_THAT(html, HasSubstr("a&lt;b&gt;.yaml"));
  EXPECT_THAT(html, ::testing::Not(HasSubstr("a<b>.yaml")));
  EXPECT_THAT(html, HasSubstr("<td>r1</td>"));
  EXPECT_THAT(html, HasSubstr("<td>0.25</td>"));
  EXPECT_THAT(html, HasSubstr("tied to no other run"));
  EXPECT_THAT(html, ::testing::Not(HasSubstr("http")));  // self-contained
}

}  // namespace
}  // namespace graphslam::tools::job
