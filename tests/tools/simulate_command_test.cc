#include "tools/simulate_command.h"

#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <string>
#include <unistd.h>
#include <vector>

#include "core/point_observation_model.h"
#include "core/relative_pose_model.h"
#include "storage/g2o_reader.h"
#include "storage/native_log_reader.h"
#include "tools/exit_codes.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools {
namespace {

std::filesystem::path ScratchPath() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return std::filesystem::temp_directory_path() /
         ("graphslam_simulate_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
}

class SimulateCommandTest : public ::testing::Test {
 protected:
  void SetUp() override { std::filesystem::remove_all(root_); }
  void TearDown() override { std::filesystem::remove_all(root_); }
  const std::filesystem::path root_ = ScratchPath();
};

TEST_F(SimulateCommandTest, WritesLogAndGroundTruthThatReadBack) {
  SimulateCommandOptions options;
  options.output_dir = (root_ / "nested" / "campus").string();  // created
  options.simulator.poses = 600;
  options.simulator.runs = 2;
  options.simulator.gps_every = 50;
  options.quiet = true;
  ASSERT_EQ(RunSimulateCommand(options), kExitOk);

  StatusOr<SimulatedCampus> campus = SimulateCampus(options.simulator);  // deterministic
  ASSERT_TRUE(campus.ok());
  const std::filesystem::path dir(options.output_dir);
  StatusOr<core::Problem2d> log = storage::ReadNativeLog((dir / "log.graphslam").string());
  ASSERT_TRUE(log.ok()) << log.status().ToString();
  EXPECT_EQ(log->num_poses(), 600);
  EXPECT_EQ(log->num_features(), campus->problem.num_features());
  EXPECT_EQ(log->observations.size(), campus->problem.observations.size());
  EXPECT_EQ(log->motions.size(), campus->problem.motions.size());
  EXPECT_EQ(log->gps.size(), campus->problem.gps.size());
  EXPECT_EQ(log->observations.back().z, campus->problem.observations.back().z);

  StatusOr<std::vector<StampedPose2>> truth = ReadTum((dir / "ground_truth.tum").string());
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  ASSERT_EQ(truth->size(), 600u);
  for (size_t i = 0; i < truth->size(); ++i) {
    EXPECT_NEAR(((*truth)[i].pose - campus->true_poses[i]).head<2>().norm(), 0.0, 1e-12);
    EXPECT_NEAR(core::WrapAngle((*truth)[i].pose.z() - campus->true_poses[i].z()), 0.0, 1e-12);
    EXPECT_DOUBLE_EQ((*truth)[i].stamp, (i % 300) * options.simulator.dt);
  }
  StatusOr<std::map<int64_t, core::Point2>> features =
      ReadFeaturesCsv((dir / "ground_truth_features.csv").string());
  ASSERT_TRUE(features.ok()) << features.status().ToString();
  ASSERT_EQ(static_cast<int64_t>(features->size()), campus->problem.num_features());
  EXPECT_EQ(features->at(1000000), campus->true_features[0]);
  EXPECT_FALSE(std::filesystem::exists(dir / "graph.g2o"));
}

TEST_F(SimulateCommandTest, G2oFormatWritesGraph) {
  SimulateCommandOptions options;
  options.output_dir = root_.string();
  options.format = "g2o";
  options.simulator.poses = 1000;
  options.quiet = true;
  ASSERT_EQ(RunSimulateCommand(options), kExitOk);
  EXPECT_TRUE(std::filesystem::exists(root_ / "graph.g2o"));
  EXPECT_TRUE(std::filesystem::exists(root_ / "ground_truth.tum"));
  EXPECT_TRUE(std::filesystem::exists(root_ / "ground_truth_features.csv"));
  EXPECT_FALSE(std::filesystem::exists(root_ / "log.graphslam"));
  StatusOr<core::Problem2d> graph = storage::ReadG2o((root_ / "graph.g2o").string());
  ASSERT_TRUE(graph.ok()) << graph.status().ToString();
  ASSERT_EQ(graph->num_poses(), 1000);
  ASSERT_EQ(graph->relative_poses.size(), 999u);

  // The converted edges still fit the truth: chi2/dof ~ 1 (2997 and ~7000
  // dimensions: sd ~0.026 and ~0.017, first-order conversions).
  StatusOr<SimulatedCampus> campus = SimulateCampus(options.simulator);
  ASSERT_TRUE(campus.ok());
  double motion_chi2 = 0.0;
  for (const core::RelativePoseConstraint& edge : graph->relative_poses) {
    Eigen::Vector3d residual;
    core::EvaluateRelativePose(campus->true_poses[edge.from], campus->true_poses[edge.to], edge.z,
                               &residual, nullptr, nullptr);
    motion_chi2 += residual.dot(edge.information * residual);
  }
  motion_chi2 /= 3.0 * static_cast<double>(graph->relative_poses.size());
  EXPECT_GT(motion_chi2, 0.9);
  EXPECT_LT(motion_chi2, 1.1);
  double point_chi2 = 0.0;
  for (const core::Observation& observation : graph->observations) {
    ASSERT_EQ(observation.kind, core::ObservationKind::kPointXY);
    Eigen::Vector2d residual;
    // g2o ids are shared: features follow the poses in the dense order.
    core::EvaluatePointObservation(campus->true_poses[observation.pose],
                                   campus->true_features[observation.feature], observation.z,
                                   &residual, nullptr, nullptr);
    point_chi2 += residual.dot(observation.information * residual);
  }
  point_chi2 /= 2.0 * static_cast<double>(graph->observations.size());
  EXPECT_GT(point_chi2, 0.9);
  EXPECT_LT(point_chi2, 1.1);
}

TEST_F(SimulateCommandTest, BadOptionsExitWithUsageBeforeWritingAnything) {
  SimulateCommandOptions options;
  options.output_dir = root_.string();
  options.quiet = true;
  options.simulator.runs = 0;
  EXPECT_EQ(RunSimulateCommand(options), kExitUsage);
  options.simulator.runs = 1;
  options.format = "tum";
  EXPECT_EQ(RunSimulateCommand(options), kExitUsage);
  options.format = "native";
  options.simulator.poses = 1;
  EXPECT_EQ(RunSimulateCommand(options), kExitUsage);
  EXPECT_FALSE(std::filesystem::exists(root_));
}

TEST_F(SimulateCommandTest, ParsesTheCommandLine) {
  CLI::App app;
  SimulateCommandOptions options;
  int exit_code = -1;
  AddSimulateCommand(&app, &options, &exit_code);
  const std::string dir = root_.string();
  app.parse("simulate -o " + dir + " --poses 200 --features 80 --runs 2 --seed 3 --gps-every 5 -q",
            /*program_name_included=*/false);
  EXPECT_EQ(exit_code, kExitOk);
  EXPECT_EQ(options.simulator.poses, 200);
  EXPECT_EQ(options.simulator.features, 80);
  EXPECT_EQ(options.simulator.runs, 2);
  EXPECT_EQ(options.simulator.gps_every, 5);
  EXPECT_EQ(options.simulator.seed, 3u);
  StatusOr<std::map<int64_t, core::Point2>> features =
      ReadFeaturesCsv((root_ / "ground_truth_features.csv").string());
  ASSERT_TRUE(features.ok());
  EXPECT_EQ(features->size(), 80u);
}

}  // namespace
}  // namespace graphslam::tools
