// MRCLAM dataset 1, robot 1, as a job: the job runner reaches the accuracy
// of `graphslam solve` with the same settings (docs/benchmarks.md: 0.105 m
// position RMSE against Vicon), and reports it from the dataset's own
// ground truth.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tests/testing/datasets.h"
#include "tools/job/job_runner.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;

TEST(JobMrclam, Dataset1RobotOneMatchesVicon) {
  GS_REQUIRE_DATASET("mrclam_dataset1_sampled50hz/Robot1_Odometry.dat");
  const fs::path dir = fs::temp_directory_path() / ("graphslam_job_mrclam_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream((dir / "job.yaml").string())
      << "output: out\n"
         "solver: {robust_kernel: 'cauchy:1', initialization: odometry}\n"
         "runs:\n"
         "  - {name: robot1, format: mrclam, robot: 1, path: '"
      << testing::DatasetPath("mrclam_dataset1_sampled50hz") << "'}\n";
  RunJobOptions options;
  options.job_path = (dir / "job.yaml").string();
  options.quiet = true;
  const Status status = RunJob(options);
  ASSERT_TRUE(status.ok()) << status.ToString();
  std::ifstream in(dir / "out/report.json");
  std::stringstream buffer;
  buffer << in.rdbuf();
  const nlohmann::json report = nlohmann::json::parse(buffer.str());
  const nlohmann::json& run = report["runs"][0];
  EXPECT_EQ(run["name"], "robot1");
  EXPECT_GT(run["matched_poses"].get<int64_t>(), 1000);
  EXPECT_LT(run["position_rmse_m"].get<double>(), 0.2);
  EXPECT_LT(run["heading_rmse_rad"].get<double>(), 0.1);
  EXPECT_TRUE(report["components"][0]["converged"].get<bool>());
  EXPECT_TRUE(fs::exists(dir / "out/trajectories/robot1.tum"));
  EXPECT_TRUE(fs::exists(dir / "out/report.html"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::tools::job
