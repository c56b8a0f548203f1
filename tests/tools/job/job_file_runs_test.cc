// A job over a run read from files (a native log with time stamps), with its
// ground truth as KITTI odometry poses plus a times file, and
// solver.repair_information:
// - trajectories/NAME_groundtruth.tum is written beside the estimate, at the
//   times of the times file, holding the true planar poses (the KITTI camera
//   frame turned back into x forward, y left);
// - the report's ATE is the known answer: the log's odometry is exact and
//   pose 0 is fixed at the truth, so the optimum is the true trajectory
//   (ATE 0, every pose matched by time; matched by index instead, the stamps
//   100 + 0.5 i of the log would meet none of the frames 0, 1, ...);
// - an ODOM information that is not positive definite fails the job naming
//   the file and line, and with the switch is repaired and counted in
//   report.json and report.html.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/se2.h"
#include "tests/testing/kitti_pose_line.h"
#include "tests/tools/job/job_test_folder.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

using JobFileRuns = JobTestFolder;

constexpr int kPoses = 80;
constexpr int kBadOdometry = 40;  // the ODOM from pose 40 to 41

// A loop of radius 10 m driven in steps of 0.1 rad, then a straight stretch.
core::Pose2 TruePose(int i) {
  if (i < 60) {
    const double a = 0.1 * i;
    return core::Pose2(10.0 * std::sin(a), 10.0 - 10.0 * std::cos(a), a);
  }
  const core::Pose2 turn_end = TruePose(59);
  return core::Compose(turn_end, core::Pose2(0.8 * (i - 59), 0.0, 0.0));
}

double Stamp(int i) { return 100.0 + 0.5 * i; }

// The native log: the header, POSE 0 (at the truth) and FIX 0, POSE 1..N-1
// (stamps only), then the exact odometry, ODOM i i+1 on line N + 3 + i.
std::string NativeLog() {
  std::string log = "GRAPHSLAM_LOG 1\n";
  char line[256];
  const core::Pose2 p0 = TruePose(0);
  std::snprintf(line, sizeof(line), "POSE 0 %.17g %.17g %.17g %.17g\nFIX 0\n", Stamp(0), p0.x(),
                p0.y(), p0.z());
  log += line;
  for (int i = 1; i < kPoses; ++i) {
    std::snprintf(line, sizeof(line), "POSE %d %.17g\n", i, Stamp(i));
    log += line;
  }
  for (int i = 0; i + 1 < kPoses; ++i) {
    const core::Pose2 z = core::Between(TruePose(i), TruePose(i + 1));
    const char* information = i == kBadOdometry ? "100 0 0 100 0 -100" : "100 0 0 100 0 100";
    std::snprintf(line, sizeof(line), "ODOM %d %d %.17g %.17g %.17g %s\n", i, i + 1, z.x(), z.y(),
                  z.z(), information);
    log += line;
  }
  return log;
}

// 1-based line of the ODOM from pose `from`.
int OdometryLine(int from) { return kPoses + 3 + from; }

// KITTI poses/NN.txt (camera poses, tests/testing/kitti_pose_line.h) and
// its times.txt.
void WriteKitti(const fs::path& poses, const fs::path& times) {
  std::ofstream kitti(poses), stamps(times);
  for (int i = 0; i < kPoses; ++i) {
    kitti << testing::KittiPoseLine(TruePose(i));
    char line[64];
    std::snprintf(line, sizeof(line), "%.17g\n", Stamp(i));
    stamps << line;
  }
}

std::string Job(bool repair) {
  return std::string("output: out\nthreads: 2\n") +
         (repair ? "solver: {repair_information: true}\n" : "") +
         "stages: [ingest, initialize, optimize, export]\n"
         "runs:\n"
         "  - name: drive\n"
         "    format: native\n"
         "    path: drive.log\n"
         "    ground_truth: {path: poses/00.txt, format: kitti, times: times.txt}\n";
}

TEST_F(JobFileRuns, KittiGroundTruthWithTimesAndRepairedInformation) {
  std::ofstream(dir_ / "drive.log") << NativeLog();
  fs::create_directories(dir_ / "poses");
  WriteKitti(dir_ / "poses" / "00.txt", dir_ / "times.txt");

  const Status rejected = Run(Job(/*repair=*/false));
  ASSERT_FALSE(rejected.ok());
  EXPECT_THAT(rejected.ToString(),
              HasSubstr("drive.log:" + std::to_string(OdometryLine(kBadOdometry)) +
                        ": ODOM information"));

  const Status status = Run(Job(/*repair=*/true));
  ASSERT_TRUE(status.ok()) << status.ToString();
  const fs::path out = dir_ / "out";

  StatusOr<std::vector<StampedPose2>> truth =
      ReadTum((out / "trajectories" / "drive_groundtruth.tum").string());
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  ASSERT_EQ(truth->size(), static_cast<size_t>(kPoses));
  for (int i = 0; i < kPoses; ++i) {
    EXPECT_DOUBLE_EQ((*truth)[i].stamp, Stamp(i)) << i;
    const core::Pose2 d = core::Between(TruePose(i), (*truth)[i].pose);
    EXPECT_LT(d.head<2>().norm(), 1e-9) << i;
    EXPECT_LT(std::abs(d.z()), 1e-9) << i;
  }
  StatusOr<std::vector<StampedPose2>> estimate =
      ReadTum((out / "trajectories" / "drive.tum").string());
  ASSERT_TRUE(estimate.ok()) << estimate.status().ToString();
  ASSERT_EQ(estimate->size(), static_cast<size_t>(kPoses));
  EXPECT_DOUBLE_EQ(estimate->back().stamp, Stamp(kPoses - 1));

  const nlohmann::json report = ReadJsonFile(out / "report.json");
  const nlohmann::json& run = report["runs"][0];
  EXPECT_EQ(run["time"], "input");
  EXPECT_EQ(run["ground_truth_trajectory"], "trajectories/drive_groundtruth.tum");
  EXPECT_EQ(run["matched_poses"].get<int64_t>(), kPoses);
  EXPECT_LT(run["position_rmse_m"].get<double>(), 1e-6);
  EXPECT_LT(run["heading_rmse_rad"].get<double>(), 1e-6);
  EXPECT_EQ(run["information_repairs"].get<int64_t>(), 1);
  EXPECT_EQ(run["information_repair_lines"], nlohmann::json({OdometryLine(kBadOdometry)}));

  const std::string html = ReadFile(out / "report.html");
  EXPECT_THAT(html, HasSubstr("Run drive: 1 information matrices were not positive definite and "
                              "were repaired (first lines: " +
                              std::to_string(OdometryLine(kBadOdometry)) + ")"));
}

}  // namespace
}  // namespace graphslam::tools::job
