// The paper's Figure 6 result as a job: a campus driven twice where GPS is
// received only outdoors. Solved with the outdoor fixes, the trajectory error
// against ground truth on the indoor poses is lower than when the same job is
// solved without any GPS (compare_without_gps), and the report shows both.
//
// The margin depends on the campus: with landmarks this dense the map is
// already good without GPS, and on some seeds (e.g. 1500 poses, 3 runs, seed
// 5, region [-10,-10,50,90]) the two are within noise of each other. This
// seed and region (most of the campus indoors, GPS on two streets) is one
// where GPS visibly helps; docs/benchmarks.md gives the default job's figures.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tools/job/job_runner.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;

TEST(JobGpsIndoor, OutdoorGpsLowersTheIndoorError) {
  const fs::path dir = fs::temp_directory_path() / ("graphslam_job_gps_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream((dir / "job.yaml").string())
      << "output: out\n"
         "compare_without_gps: true\n"
         "runs:\n"
         "  - name: campus\n"
         "    format: simulate\n"
         "    simulate: {poses: 2000, runs: 2, seed: 7, sensor_range: 8, range_sigma: 0.3,\n"
         "               bearing_sigma: 0.05, gps_every: 5, gps_sigma: 0.5,\n"
         "               gps_denied_region: [-10, -10, 90, 50]}\n";
  RunJobOptions options;
  options.job_path = (dir / "job.yaml").string();
  options.quiet = true;
  const Status status = RunJob(options);
  ASSERT_TRUE(status.ok()) << status.ToString();
  std::ifstream in(dir / "out/report.json");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const nlohmann::json report = nlohmann::json::parse(buffer.str());
  ASSERT_TRUE(report.contains("gps_comparison")) << report.dump(1);
  const nlohmann::json& c = report["gps_comparison"];
  EXPECT_GT(c["indoor_poses"].get<int>(), 500);
  const double with_gps = c["indoor_rmse_with_gps_m"].get<double>();
  const double without_gps = c["indoor_rmse_without_gps_m"].get<double>();
  EXPECT_LT(with_gps, 0.9 * without_gps) << "with " << with_gps << " without " << without_gps;
  EXPECT_LT(c["position_rmse_with_gps_m"].get<double>(), c["position_rmse_without_gps_m"].get<double>());
  // Both runs received fixes outdoors, none indoors.
  for (const nlohmann::json& run : report["runs"]) {
    EXPECT_GT(run["gps_fixes"].get<int>(), 0);
    EXPECT_GT(run["indoor_poses"].get<int>(), 0);
  }
  // The HTML report shows the comparison.
  std::ifstream html_in(dir / "out/report.html");
  std::stringstream html;
  html << html_in.rdbuf();
  EXPECT_NE(html.str().find("<table class=\"gps-comparison\""), std::string::npos);
  EXPECT_NE(html.str().find("<th>without GPS</th>"), std::string::npos);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::tools::job
