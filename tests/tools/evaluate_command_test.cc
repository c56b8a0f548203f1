#include "tools/evaluate_command.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>

#include "storage/features_csv_writer.h"
#include "storage/mrclam_reader.h"
#include "storage/tum_writer.h"
#include "tests/testing/datasets.h"
#include "tests/testing/kitti_pose_line.h"
#include "tools/campus_simulator.h"
#include "tools/exit_codes.h"
#include "tools/simulate_command.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools {
namespace {

class EvaluateCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            ("graphslam_evaluate_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  void TearDown() override { std::filesystem::remove_all(root_); }

  // Simulates a campus into root_ (ground_truth.tum, ground_truth_features.csv).
  CampusSimulatorOptions Simulate() {
    SimulateCommandOptions options;
    options.output_dir = root_.string();
    options.simulator.poses = 800;
    options.simulator.runs = 2;
    options.quiet = true;
    EXPECT_EQ(RunSimulateCommand(options), kExitOk);
    return options.simulator;
  }
  std::string Path(const std::string& name) const { return (root_ / name).string(); }

  static nlohmann::json ReadJson(const std::string& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
  }

  std::filesystem::path root_;
};

TEST_F(EvaluateCommandTest, GroundTruthAgainstItselfHasZeroError) {
  Simulate();
  EvaluateCommandOptions options;
  options.trajectory = Path("ground_truth.tum");
  options.ground_truth = Path("ground_truth.tum");
  options.features = Path("ground_truth_features.csv");
  options.ground_truth_features = Path("ground_truth_features.csv");
  options.report = Path("report.json");
  options.quiet = true;
  ASSERT_EQ(RunEvaluateCommand(options), kExitOk);
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["matched_poses"].get<int64_t>(), 800);
  EXPECT_EQ(report["runs"].get<int64_t>(), 2);
  EXPECT_LT(report["position_rmse_m"].get<double>(), 1e-9);
  EXPECT_LT(report["heading_rmse_rad"].get<double>(), 1e-9);
  EXPECT_GT(report["features"]["matched"].get<int64_t>(), 50);
  EXPECT_EQ(report["features"]["missing"].get<int64_t>(), 0);
  EXPECT_LT(report["features"]["rmse_trajectory_aligned_m"].get<double>(), 1e-9);
  EXPECT_LT(report["features"]["rmse_self_aligned_m"].get<double>(), 1e-9);
}

TEST_F(EvaluateCommandTest, DeadReckoningAgainstTruthMatchesTheLibrary) {
  const CampusSimulatorOptions simulator = Simulate();
  // The simulator's hints (dead reckoning, first-sight features) as the "estimate".
  StatusOr<SimulatedCampus> campus = SimulateCampus(simulator);
  ASSERT_TRUE(campus.ok());
  ASSERT_TRUE(storage::WriteTum(campus->problem, Path("estimate.tum")).ok());
  ASSERT_TRUE(storage::WriteFeaturesCsv(campus->problem, Path("estimate.csv")).ok());
  EvaluateCommandOptions options;
  options.trajectory = Path("estimate.tum");
  options.ground_truth = Path("ground_truth.tum");
  options.features = Path("estimate.csv");
  options.ground_truth_features = Path("ground_truth_features.csv");
  options.report = Path("report.json");
  options.quiet = true;
  ASSERT_EQ(RunEvaluateCommand(options), kExitOk);
  const nlohmann::json report = ReadJson(options.report);

  StatusOr<TrajectoryErrors> expected =
      CompareTrajectories(*ReadTum(options.trajectory), *ReadTum(options.ground_truth));
  ASSERT_TRUE(expected.ok());
  EXPECT_GT(expected->position_rmse, 0.1);
  EXPECT_DOUBLE_EQ(report["position_rmse_m"].get<double>(), expected->position_rmse);
  EXPECT_DOUBLE_EQ(report["heading_rmse_rad"].get<double>(), expected->heading_rmse_rad);
  EXPECT_GT(report["features"]["rmse_trajectory_aligned_m"].get<double>(), 0.1);
}

TEST_F(EvaluateCommandTest, UsageErrorsExitWithOneAndBadFilesWithTwo) {
  Simulate();
  EvaluateCommandOptions options;
  options.quiet = true;
  EXPECT_EQ(RunEvaluateCommand(options), kExitUsage);  // no --trajectory
  options.trajectory = Path("ground_truth.tum");
  EXPECT_EQ(RunEvaluateCommand(options), kExitUsage);  // no ground truth
  options.ground_truth = Path("ground_truth.tum");
  options.mrclam = root_.string();
  EXPECT_EQ(RunEvaluateCommand(options), kExitUsage);  // two ground truths
  options.mrclam.clear();
  options.features = Path("ground_truth_features.csv");
  EXPECT_EQ(RunEvaluateCommand(options), kExitUsage);  // features without truth
  options.features.clear();
  options.ground_truth_features = Path("ground_truth_features.csv");
  EXPECT_EQ(RunEvaluateCommand(options), kExitUsage);  // truth features without estimate
  options.ground_truth_features.clear();

  options.ground_truth = Path("missing.tum");
  EXPECT_EQ(RunEvaluateCommand(options), kExitBadInput);
  std::ofstream(Path("bad.tum")) << "0 1 2 0 0 0 0 1\n0.5 1 2\n";
  options.ground_truth = Path("bad.tum");
  options.report = Path("report.json");
  EXPECT_EQ(RunEvaluateCommand(options), kExitBadInput);
  EXPECT_FALSE(std::filesystem::exists(options.report));
}

TEST_F(EvaluateCommandTest, MrclamGroundTruthItselfHasZeroError) {
  GS_REQUIRE_DATASET("mrclam_dataset1_sampled50hz/Robot1_Groundtruth.dat");
  const std::string folder = testing::DatasetPath("mrclam_dataset1_sampled50hz");
  StatusOr<storage::MrclamGroundTruth> truth = storage::ReadMrclamGroundTruth(folder, 1);
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  // The ground truth written as an estimate: TUM + features keyed by subject.
  core::Problem2d problem;
  // Past t = 1000 s the file's stamps have 0.1 s resolution (printed with 5
  // digits), so several poses share one stamp and nearest-stamp matching is
  // ambiguous there: use the first 1000 s only.
  for (size_t i = 0; i < truth->poses.size() && truth->stamps[i] < 999.0; i += 10) {
    problem.AddPose(static_cast<int64_t>(i), truth->poses[i], true, 0, truth->stamps[i]);
  }
  for (const auto& [subject, position] : truth->landmarks) problem.AddFeature(subject, position, true);
  ASSERT_TRUE(storage::WriteTum(problem, Path("estimate.tum")).ok());
  ASSERT_TRUE(storage::WriteFeaturesCsv(problem, Path("estimate.csv")).ok());

  EvaluateCommandOptions options;
  options.trajectory = Path("estimate.tum");
  options.features = Path("estimate.csv");
  options.mrclam = folder;
  options.robot = 1;
  options.report = Path("report.json");
  options.quiet = true;
  ASSERT_EQ(RunEvaluateCommand(options), kExitOk);
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["matched_poses"].get<int64_t>(), problem.num_poses());
  EXPECT_LT(report["position_rmse_m"].get<double>(), 1e-9);
  EXPECT_EQ(report["features"]["matched"].get<int64_t>(),
            static_cast<int64_t>(truth->landmarks.size()));
  EXPECT_LT(report["features"]["rmse_self_aligned_m"].get<double>(), 1e-9);
}

// KITTI poses as ground truth: camera frame (x right, y down, z forward) of
// the true planar poses; the estimate is the truth moved rigidly, with stamps
// = pose index (matched by index) or with the times of a times file.
TEST_F(EvaluateCommandTest, KittiGroundTruthMatchesByIndexOrByTimesFile) {
  CampusSimulatorOptions simulator;
  simulator.poses = 300;
  StatusOr<SimulatedCampus> campus = SimulateCampus(simulator);
  ASSERT_TRUE(campus.ok());
  std::ofstream kitti(Path("00.txt")), times(Path("times.txt"));
  core::Problem2d by_index, by_time;
  const core::Pose2 moved(5.0, -3.0, 0.7);
  for (size_t i = 0; i < campus->true_poses.size(); ++i) {
    const core::Pose2& p = campus->true_poses[i];
    kitti << testing::KittiPoseLine(p);
    times << campus->problem.pose_stamps[i] << "\n";
    by_index.AddPose(static_cast<int64_t>(i), core::Compose(moved, p), true, 0);
    by_time.AddPose(static_cast<int64_t>(i), core::Compose(moved, p), true, 0,
                    campus->problem.pose_stamps[i]);
  }
  kitti.close();
  times.close();
  ASSERT_TRUE(storage::WriteTum(by_index, Path("by_index.tum")).ok());
  ASSERT_TRUE(storage::WriteTum(by_time, Path("by_time.tum")).ok());
  for (const bool with_times : {false, true}) {
    EvaluateCommandOptions options;
    options.trajectory = Path(with_times ? "by_time.tum" : "by_index.tum");
    options.ground_truth = Path("00.txt");
    if (with_times) options.ground_truth_times = Path("times.txt");
    options.report = Path("report.json");
    options.quiet = true;
    ASSERT_EQ(RunEvaluateCommand(options), kExitOk) << with_times;
    const nlohmann::json report = ReadJson(options.report);
    EXPECT_EQ(report["matched_poses"].get<int64_t>(), 300) << with_times;
    EXPECT_LT(report["position_rmse_m"].get<double>(), 1e-6) << with_times;
    EXPECT_LT(report["heading_rmse_rad"].get<double>(), 1e-9) << with_times;
    EXPECT_NEAR(report["alignment"]["theta"].get<double>(), -0.7, 1e-9) << with_times;
  }
  // Malformed KITTI: exit 2, nothing written; a times file without KITTI: exit 1.
  std::ofstream(Path("bad.txt")) << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1\n";
  EvaluateCommandOptions bad;
  bad.trajectory = Path("by_index.tum");
  bad.ground_truth = Path("bad.txt");
  bad.ground_truth_format = "kitti";
  bad.quiet = true;
  EXPECT_EQ(RunEvaluateCommand(bad), kExitBadInput);
  bad.ground_truth_format = "euroc";
  EXPECT_EQ(RunEvaluateCommand(bad), kExitUsage);
}

}  // namespace
}  // namespace graphslam::tools
