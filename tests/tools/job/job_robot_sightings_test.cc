// Two robots that only see each other (no landmark at all), as an MRCLAM
// dataset folder: a job of the two runs ties them by their robot-to-robot
// constraints alone (tools/job/robot_sightings.h) and maps both in one frame,
// each robot starting at the origin of its own frame. The same robots in two
// different dataset folders (so nothing says they drove together) stay two
// components.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>

#include "core/angle.h"
#include "core/velocity_motion_model.h"
#include "storage/native_log_reader.h"
#include "tests/tools/job/job_test_folder.h"
#include "tools/job/robot_sightings.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;

constexpr int kSteps = 3000;         // 60 s at 50 Hz
constexpr int kSightingEvery = 25;   // 0.5 s
constexpr double kDt = 0.02;

struct Robot {
  core::Pose2 start;
  double v = 0.0, omega = 0.0;
  std::vector<core::Pose2> truth;
};

std::string Stamp(int k) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.2f", k * kDt);
  return buffer;
}

// Writes robots 1 and 2 (barcodes 5 and 14) into `folder`: Vicon ground
// truth, odometry with zero-mean noise, and every 0.5 s each robot's
// range-bearing measurement of the other. (Without landmarks a drift common
// to both robots is unobservable, so the odometry has no bias: what is tested
// is the relative placement of the two robots, which only the sightings give;
// each starts at the origin of its own frame, 4.5 m and 180 degrees from the
// truth of the other.) With robot2_stride > 1, robot 2's odometry and
// measurements are kept at every robot2_stride-th step only (its poses are
// that much sparser than robot 1's sightings of it).
void WriteDataset(const fs::path& folder, Robot* robots, int robot2_stride = 1) {
  fs::create_directories(folder);
  std::ofstream(folder / "Barcodes.dat") << "# Subject # Barcode #\n1 5\n2 14\n6 72\n";
  std::ofstream(folder / "Landmark_Groundtruth.dat") << "# Subject # x y sx sy (no landmark)\n";
  std::mt19937_64 engine(11);
  std::normal_distribution<double> normal;
  const int barcode[2] = {5, 14};
  for (int r = 0; r < 2; ++r) {
    Robot& robot = robots[r];
    robot.truth.assign(1, robot.start);
    std::ofstream odometry(folder / ("Robot" + std::to_string(r + 1) + "_Odometry.dat"));
    std::ofstream truth(folder / ("Robot" + std::to_string(r + 1) + "_Groundtruth.dat"));
    for (int k = 0; k < kSteps; ++k) {
      core::VelocityControl control;
      control.v = robot.v;
      control.omega = robot.omega;
      control.dt = kDt;
      if (k + 1 < kSteps) robot.truth.push_back(core::PredictVelocityMotion(robot.truth.back(), control));
      const core::Pose2& x = robot.truth[static_cast<size_t>(k)];
      truth << Stamp(k) << " " << x.x() << " " << x.y() << " " << x.z() << "\n";
      if (r == 1 && k % robot2_stride != 0) continue;
      odometry << Stamp(k) << " " << robot.v + 0.02 * normal(engine) << " "
               << robot.omega + 0.02 * normal(engine) << "\n";
    }
  }
  for (int r = 0; r < 2; ++r) {
    std::ofstream measurement(folder / ("Robot" + std::to_string(r + 1) + "_Measurement.dat"));
    measurement.precision(17);
    for (int k = 0; k < kSteps; k += kSightingEvery) {
      if (r == 1 && k % robot2_stride != 0) continue;
      const core::Pose2& a = robots[r].truth[static_cast<size_t>(k)];
      const core::Pose2& b = robots[1 - r].truth[static_cast<size_t>(k)];
      const Eigen::Vector2d d = b.head<2>() - a.head<2>();
      const double range = d.norm() + 0.03 * normal(engine);
      const double bearing = core::WrapAngle(std::atan2(d.y(), d.x()) - a.z() + 0.01 * normal(engine));
      measurement << Stamp(k) << " " << barcode[1 - r] << " " << range << " " << bearing << "\n";
    }
  }
}

// Two circles that overlap, driven at the same time.
void OverlappingCircles(Robot* robots) {
  robots[0].start = core::Pose2(3.0, 0.0, std::numbers::pi / 2);
  robots[0].v = 0.3;
  robots[0].omega = 0.1;
  robots[1].start = core::Pose2(-1.0, 1.0, -std::numbers::pi / 2);
  robots[1].v = 0.2;
  robots[1].omega = -0.1;
}

class JobRobotSightings : public JobTestFolder {};

TEST_F(JobRobotSightings, TwoRobotsThatOnlySeeEachOtherEndInOneFrame) {
  Robot robots[2];
  OverlappingCircles(robots);
  WriteDataset(dir_ / "together", robots);
  const std::string solver = "solver: {initialization: odometry}\n";
  const Status together = Run("output: out\n" + solver +
                              "runs:\n"
                              "  - {name: r1, format: mrclam, robot: 1, path: together}\n"
                              "  - {name: r2, format: mrclam, robot: 2, path: together}\n");
  ASSERT_TRUE(together.ok()) << together.ToString();
  const nlohmann::json report = ReadJsonFile(dir_ / "out/report.json");
  ASSERT_EQ(report["components"].size(), 1u);
  EXPECT_TRUE(report["runs"][0]["tied"].get<bool>());
  EXPECT_TRUE(report["runs"][1]["tied"].get<bool>());
  // 120 sightings each way, all on the shared 0.02 s grid.
  const int expected = 2 * kSteps / kSightingEvery;
  EXPECT_EQ(report["robot_sightings"]["constraints"].get<int>(), expected);
  EXPECT_EQ(report["robot_sightings"]["no_pose_at_stamp"].get<int>(), 0);
  ASSERT_EQ(report["robot_sightings"]["pairs"].size(), 1u);
  EXPECT_EQ(report["robot_sightings"]["pairs"][0]["runs"], nlohmann::json({"r1", "r2"}));
  EXPECT_EQ(report["robot_sightings"]["pairs"][0]["constraints"].get<int>(), expected);
  // One frame: after ONE rigid alignment of both runs together, both lie on
  // their Vicon paths.
  ASSERT_EQ(report["joint_trajectory_errors"].size(), 1u);
  const nlohmann::json& joint = report["joint_trajectory_errors"][0];
  EXPECT_EQ(joint["matched_poses"].get<int>(), 2 * kSteps);
  // (0.013 m here; a robot left where its own frame puts it would be metres off.)
  EXPECT_LT(joint["position_rmse_m"].get<double>(), 0.05);
  for (const nlohmann::json& run : joint["runs"]) {
    EXPECT_LT(run["position_rmse_m"].get<double>(), 0.05) << run["name"];
    EXPECT_LT(run["heading_rmse_rad"].get<double>(), 0.1) << run["name"];
  }
  EXPECT_DOUBLE_EQ(report["runs"][1]["joint_position_rmse_m"].get<double>(),
                   joint["runs"][1]["position_rmse_m"].get<double>());

  // The same files in two folders: nothing ties the robots.
  fs::create_directories(dir_ / "apart");
  fs::copy(dir_ / "together", dir_ / "apart", fs::copy_options::recursive);
  // Runs a job of r1 (folder together) and r2 (folder second) writing to
  // `output`; its report, expected in two components.
  const auto untied = [&](const std::string& output, const std::string& head,
                          const std::string& second) {
    const Status status = Run("output: " + output + "\n" + head + solver +
                                  "runs:\n"
                                  "  - {name: r1, format: mrclam, robot: 1, path: together}\n"
                                  "  - {name: r2, format: mrclam, robot: 2, path: " + second +
                                  "}\n",
                              output + ".yaml");
    EXPECT_TRUE(status.ok()) << status.ToString();
    const nlohmann::json report = ReadJsonFile(dir_ / output / "report.json");
    EXPECT_EQ(report["components"].size(), 2u) << output;
    EXPECT_FALSE(report["runs"][1]["tied"].get<bool>()) << output;
    return report;
  };
  const nlohmann::json apart = untied("out2", "", "apart");
  EXPECT_EQ(apart["robot_sightings"]["constraints"].get<int>(), 0);
  EXPECT_EQ(apart["robot_sightings"]["robot_not_in_job"].get<int>(), expected);
  // The same folder with robot_sightings: false: the constraints are left out.
  untied("out3", "robot_sightings: false\n", "together");
}

// Robot 2 has a pose every 0.04 s only (every other odometry record), so
// robot 1's sightings of it at odd multiples of 0.02 s fall half-way between
// two of its poses: each becomes an interpolated constraint (alpha = 0.5),
// none is dropped or snapped, and the job still puts both in one frame.
TEST_F(JobRobotSightings, SightingsBetweenTheObservedRobotsPosesAreInterpolated) {
  Robot robots[2];
  OverlappingCircles(robots);
  WriteDataset(dir_ / "sparse", robots, /*robot2_stride=*/2);
  // The default (incremental) initialization: its stages take the
  // three-pose constraints too (partition/initialization/incremental_initialization.h).
  const Status status = Run("output: out\n"
                            "runs:\n"
                            "  - {name: r1, format: mrclam, robot: 1, path: sparse}\n"
                            "  - {name: r2, format: mrclam, robot: 2, path: sparse}\n");
  ASSERT_TRUE(status.ok()) << status.ToString();
  const nlohmann::json report = ReadJsonFile(dir_ / "out/report.json");
  // Robot 1 reads robot 2 at k = 0, 25, 50, ...: the odd k (every other
  // sighting) lie between robot 2's poses. Robot 2 reads robot 1 only at even k.
  const int sightings = kSteps / kSightingEvery;
  const nlohmann::json& counts = report["robot_sightings"];
  EXPECT_EQ(counts["constraints"].get<int>(), sightings + sightings / 2);
  EXPECT_EQ(counts["interpolated"].get<int>(), sightings / 2);
  EXPECT_EQ(counts["no_pose_at_stamp"].get<int>(), 0);
  ASSERT_EQ(report["components"].size(), 1u);
  // The interpolated constraints went through the native log between stages.
  const StatusOr<core::Problem2d> ingested =
      storage::ReadNativeLog((dir_ / "out/.job/ingested.graphslam").string());
  ASSERT_TRUE(ingested.ok()) << ingested.status().ToString();
  int interpolated = 0;
  for (const core::PoseRangeBearingConstraint& c : ingested->pose_range_bearings) {
    if (!c.interpolated()) continue;
    ++interpolated;
    EXPECT_EQ(c.to_next, c.to + 1);
    EXPECT_NEAR(c.alpha, 0.5, 1e-9);
    EXPECT_NEAR(ingested->pose_stamps[static_cast<size_t>(c.to_next)] -
                    ingested->pose_stamps[static_cast<size_t>(c.to)],
                0.04, 1e-9);
  }
  EXPECT_EQ(interpolated, sightings / 2);
  ASSERT_EQ(report["joint_trajectory_errors"].size(), 1u);
  for (const nlohmann::json& run : report["joint_trajectory_errors"][0]["runs"])
    EXPECT_LT(run["position_rmse_m"].get<double>(), 0.05) << run["name"];
}

// Robot `robot` of one dataset folder, poses [first, first + count).
RunSightings RobotRun(int robot, int32_t first, int32_t count) {
  RunSightings run;
  run.dataset = "/data";
  run.robot = robot;
  run.first_pose = first;
  run.num_poses = count;
  return run;
}

// Robot A stands still for poses 0-3 (controls below the deadband), robot B
// for its poses 0-1 and then drives: A's sightings of B while both stand are
// one constraint (the mean of the readings, circular in the bearing, the first
// reading's information); once B moves, each sighting is its own.
TEST(RobotSightingsStandstill, RepeatsWhileBothStandBecomeOneConstraint) {
  core::Problem2d problem;
  const double controls[2][4] = {{0.0, 0.004, 0.0, 0.0}, {0.0, 0.2, 0.2, 0.2}};
  for (int r = 0; r < 2; ++r) {
    for (int k = 0; k < 5; ++k) {
      const int32_t pose = problem.AddPose(10 * r + k, core::Pose2::Zero(), k == 0, 0, 0.02 * k);
      if (k == 0) continue;
      core::VelocityMotionConstraint motion;
      motion.from = pose - 1;
      motion.to = pose;
      motion.control.omega = controls[r][k - 1];
      motion.control.dt = 0.02;
      problem.motions.push_back(motion);
    }
  }
  RunSightings a = RobotRun(1, 0, 5), b = RobotRun(2, 5, 5);
  for (int k = 0; k < 4; ++k) {
    storage::MrclamRobotSighting sighting;
    sighting.stamp = 0.02 * k;
    sighting.observed_robot = 2;
    sighting.z = Eigen::Vector2d(2.0 + 0.1 * k, k % 2 == 0 ? 3.1 : -3.1);
    sighting.information = Eigen::Vector2d(100.0 - k, 400.0).asDiagonal();
    sighting.line = k + 1;
    a.sightings.push_back(sighting);
  }
  const SightingCounts counts = AddRobotSightings({a, b}, kDefaultSightingMaxTimeDifference,
                                                  kDefaultSightingMaxInterpolationGap, &problem);
  // Sightings at poses 0 and 1 (B stands for poses 0-1) merge; 2 and 3 do not.
  EXPECT_EQ(counts.standstill_repeats_merged, 1);
  EXPECT_EQ(counts.constraints, 3);
  ASSERT_EQ(problem.pose_range_bearings.size(), 3u);
  const core::PoseRangeBearingConstraint& merged = problem.pose_range_bearings[0];
  EXPECT_EQ(merged.from, 0);
  EXPECT_EQ(merged.to, 5);
  EXPECT_NEAR(merged.z.x(), 2.05, 1e-12);
  EXPECT_NEAR(std::abs(merged.z.y()), std::numbers::pi, 1e-12);
  EXPECT_EQ(merged.information, Eigen::Matrix2d(Eigen::Vector2d(100.0, 400.0).asDiagonal()));
  EXPECT_EQ(problem.pose_range_bearings[2].information,
            Eigen::Matrix2d(Eigen::Vector2d(97.0, 400.0).asDiagonal()));
  EXPECT_EQ(problem.pose_range_bearings[1].from, 2);
  EXPECT_EQ(problem.pose_range_bearings[1].to, 7);
  EXPECT_EQ(problem.pose_range_bearings[2].z, Eigen::Vector2d(2.3, -3.1));
}

// Where the observed robot B was at each sighting: at its pose (t = 0.1 s),
// between two poses (t = 0.02 s: alpha = 0.2 between B's poses at 0 and
// 0.1 s), in a gap longer than the limit (0.5 s, between 0.2 and 1.0 s), after
// its last pose (1.1 s); A, the observer, has a pose every 0.02 s.
TEST(RobotSightingsInterpolation, BetweenTwoPosesAtOneOrNone) {
  core::Problem2d problem;
  for (int k = 0; k <= 60; ++k) problem.AddPose(k, core::Pose2::Zero(), k == 0, 0, 0.02 * k);
  for (const double stamp : {0.0, 0.1, 0.2, 1.0})
    problem.AddPose(100 + problem.num_poses(), core::Pose2::Zero(), false, 0, stamp);
  RunSightings a = RobotRun(1, 0, 61), b = RobotRun(2, 61, 4);
  for (const double stamp : {0.02, 0.1, 0.5, 1.1}) {
    storage::MrclamRobotSighting sighting;
    sighting.stamp = stamp;
    sighting.observed_robot = 2;
    sighting.z = Eigen::Vector2d(2.0, 0.1);
    a.sightings.push_back(sighting);
  }
  const SightingCounts counts = AddRobotSightings({a, b}, kDefaultSightingMaxTimeDifference,
                                                  kDefaultSightingMaxInterpolationGap, &problem);
  EXPECT_EQ(counts.constraints, 2);
  EXPECT_EQ(counts.interpolated, 1);
  EXPECT_EQ(counts.no_pose_at_stamp, 2);
  ASSERT_EQ(problem.pose_range_bearings.size(), 2u);
  const core::PoseRangeBearingConstraint& between = problem.pose_range_bearings[0];
  EXPECT_EQ(between.from, 1);
  EXPECT_EQ(between.to, 61);
  EXPECT_EQ(between.to_next, 62);
  EXPECT_NEAR(between.alpha, 0.2, 1e-12);
  const core::PoseRangeBearingConstraint& at = problem.pose_range_bearings[1];
  EXPECT_EQ(at.from, 5);
  EXPECT_EQ(at.to, 62);
  EXPECT_FALSE(at.interpolated());
  EXPECT_EQ(at.alpha, 0.0);
}

}  // namespace
}  // namespace graphslam::tools::job
