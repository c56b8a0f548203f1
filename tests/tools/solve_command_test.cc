// End-to-end tests of `graphslam solve` (tools/solve_command.h): exit codes
// (tools/exit_codes.h, docs/cli.md), the files it writes and, above all, the
// files it must not write when the input is bad, plus two
// real datasets (Victoria Park: counts only; MRCLAM: accuracy against Vicon).
#include "tools/solve_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <unistd.h>
#include <utility>
#include <vector>

#include "storage/g2o_reader.h"
#include "storage/mrclam_reader.h"
#include "tests/testing/datasets.h"
#include "tools/exit_codes.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools {
namespace {

using ::testing::HasSubstr;

// A small pose + landmark problem: five poses along the x axis (truth (i, 0,
// 0)), three landmarks (truth (1, 2), (3, -2), (2, 2)), odometry and point
// observations with a little noise, and initial guesses that are off in
// position and heading, so Levenberg-Marquardt needs several iterations.
// Line k of the file is element k - 1 of this vector (bad-input tests replace
// or append lines and check the reported line number).
std::vector<std::string> SmallProblemLines() {
  return {
      "# small pose + landmark problem",            // line 1
      "VERTEX_SE2 0 0 0 0",                         // line 2
      "VERTEX_SE2 1 1.2 0.3 0.2",                   // line 3
      "VERTEX_SE2 2 2.3 -0.4 -0.3",                 // line 4
      "VERTEX_SE2 3 2.6 0.5 0.35",                  // line 5
      "VERTEX_SE2 4 4.4 -0.5 -0.25",                // line 6
      "VERTEX_XY 10 1.4 2.5",                       // line 7
      "VERTEX_XY 11 2.5 -1.5",                      // line 8
      "VERTEX_XY 12 2.4 2.4",                       // line 9
      "EDGE_SE2 0 1 1.01 0.02 0.01 100 0 0 100 0 400",     // line 10
      "EDGE_SE2 1 2 0.98 -0.01 -0.02 100 0 0 100 0 400",   // line 11
      "EDGE_SE2 2 3 1.02 0.01 0.015 100 0 0 100 0 400",    // line 12
      "EDGE_SE2 3 4 0.99 0.02 -0.01 100 0 0 100 0 400",    // line 13
      "EDGE_SE2_XY 0 10 1.01 2.02 100 0 100",       // line 14
      "EDGE_SE2_XY 1 10 0.02 1.98 100 0 100",       // line 15
      "EDGE_SE2_XY 2 10 -0.99 2.01 100 0 100",      // line 16
      "EDGE_SE2_XY 1 12 0.99 2.02 100 0 100",       // line 17
      "EDGE_SE2_XY 2 12 0.01 1.99 100 0 100",       // line 18
      "EDGE_SE2_XY 3 12 -1.02 2.0 100 0 100",       // line 19
      "EDGE_SE2_XY 2 11 1.01 -2.01 100 0 100",      // line 20
      "EDGE_SE2_XY 3 11 -0.01 -1.99 100 0 100",     // line 21
      "EDGE_SE2_XY 4 11 -1.0 -2.02 100 0 100",      // line 22
      "EDGE_SE2_XY 4 12 -2.01 1.98 100 0 100",      // line 23
  };
}
constexpr int kSmallPoses = 5;
constexpr int kSmallFeatures = 3;
constexpr int kSmallObservations = 10;
constexpr int kSmallOdometry = 4;

class SolveCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            ("graphslam_solve_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  void TearDown() override { std::filesystem::remove_all(root_); }

  std::string Path(const std::string& name) const { return (root_ / name).string(); }

  std::string WriteLines(const std::string& name, const std::vector<std::string>& lines) const {
    std::ofstream out(Path(name));
    for (const std::string& line : lines) out << line << "\n";
    return Path(name);
  }

  // Options writing all four outputs into root_, quietly.
  SolveCommandOptions AllOutputs(const std::string& input) const {
    SolveCommandOptions options;
    options.input = input;
    options.output_g2o = Path("out.g2o");
    options.report = Path("report.json");
    options.tum = Path("out.tum");
    options.features_csv = Path("features.csv");
    options.quiet = true;
    return options;
  }

  // Names of the files in root_, sorted.
  std::vector<std::string> Files() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(root_))
      names.push_back(entry.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }

  // Runs the solve with stderr captured; returns (exit code, stderr).
  static std::pair<int, std::string> RunCapturingStderr(const SolveCommandOptions& options) {
    ::testing::internal::CaptureStderr();
    const int code = RunSolveCommand(options);
    return {code, ::testing::internal::GetCapturedStderr()};
  }

  static std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }

  static nlohmann::json ReadJson(const std::string& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
  }

  std::filesystem::path root_;
};

TEST_F(SolveCommandTest, SmallProblemSolvesAndWritesEveryOutput) {
  const std::string input = WriteLines("in.g2o", SmallProblemLines());
  const SolveCommandOptions options = AllOutputs(input);
  ASSERT_EQ(RunSolveCommand(options), kExitOk);

  for (const std::string& path :
       {options.output_g2o, options.report, options.tum, options.features_csv}) {
    EXPECT_TRUE(std::filesystem::exists(path)) << path;
  }
  EXPECT_THAT(Files(), ::testing::ElementsAre("features.csv", "in.g2o", "out.g2o", "out.tum",
                                              "report.json"));

  const nlohmann::json report = ReadJson(options.report);
  for (const char* key : {"initial_chi2", "final_chi2", "iterations", "poses", "features",
                          "observations", "solver", "seconds", "peak_rss_bytes",
                          "residual_dimension", "unknowns", "per_iteration"}) {
    EXPECT_TRUE(report.contains(key)) << "report lacks " << key << ":\n" << report.dump(2);
  }
  ASSERT_TRUE(report["per_iteration"].is_array());
  ASSERT_FALSE(report["per_iteration"].empty());
  for (const nlohmann::json& iteration : report["per_iteration"]) {
    ASSERT_TRUE(iteration.is_object());
    for (const char* key : {"chi2", "step_norm", "linear_solver_iterations", "seconds"}) {
      EXPECT_TRUE(iteration.contains(key)) << "per_iteration entry lacks " << key;
    }
  }
  EXPECT_EQ(report["per_iteration"].size(), report["iterations"].get<size_t>());
  EXPECT_EQ(report["poses"].get<int>(), kSmallPoses);
  EXPECT_EQ(report["features"].get<int>(), kSmallFeatures);
  EXPECT_EQ(report["observations"].get<int>(), kSmallObservations);
  // 4 odometry edges x 3 + 10 observations x 2; 4 free poses x 3 + 3 features x 2.
  EXPECT_EQ(report["residual_dimension"].get<int>(), 3 * kSmallOdometry + 2 * kSmallObservations);
  EXPECT_EQ(report["unknowns"].get<int>(), 3 * (kSmallPoses - 1) + 2 * kSmallFeatures);
  const double initial_chi2 = report["initial_chi2"].get<double>();
  const double final_chi2 = report["final_chi2"].get<double>();
  EXPECT_LE(final_chi2, initial_chi2);
  EXPECT_GT(initial_chi2, 100.0 * final_chi2) << "the perturbed guess should cost far more";
  EXPECT_GT(report["iterations"].get<int>(), 1);
  EXPECT_GT(report["peak_rss_bytes"].get<int64_t>(), 0);
  EXPECT_GE(report["seconds"].get<double>(), 0.0);

  // The written graph reads back with the same counts.
  StatusOr<core::Problem2d> written = storage::ReadG2o(options.output_g2o);
  ASSERT_TRUE(written.ok()) << written.status().ToString();
  EXPECT_EQ(written->num_poses(), kSmallPoses);
  EXPECT_EQ(written->num_features(), kSmallFeatures);
  EXPECT_EQ(static_cast<int>(written->observations.size()), kSmallObservations);
  EXPECT_EQ(static_cast<int>(written->relative_poses.size()), kSmallOdometry);
  // Pose 1 is near its true place (1, 0, 0), not where the guess put it.
  EXPECT_NEAR(written->poses[1].x(), 1.0, 0.05);
  EXPECT_NEAR(written->poses[1].y(), 0.0, 0.05);
  EXPECT_NEAR(written->poses[1].z(), 0.0, 0.05);

  StatusOr<std::vector<StampedPose2>> tum = ReadTum(options.tum);
  ASSERT_TRUE(tum.ok()) << tum.status().ToString();
  EXPECT_EQ(static_cast<int>(tum->size()), kSmallPoses);
  StatusOr<std::map<int64_t, core::Point2>> features = ReadFeaturesCsv(options.features_csv);
  ASSERT_TRUE(features.ok()) << features.status().ToString();
  EXPECT_EQ(static_cast<int>(features->size()), kSmallFeatures);
  EXPECT_EQ(features->count(10), 1u);
}

struct BadInputCase {
  const char* name;
  int line;              // 1-based line to replace; past the end: append
  const char* content;
  const char* expected;  // a piece of the message
};

// Each case breaks one line of the small problem; the error must name that line.
const BadInputCase kBadInputCases[] = {
    {"malformed number", 4, "VERTEX_SE2 2 2.3 abc -0.3", "abc"},
    {"non-finite number", 8, "VERTEX_XY 11 2.5 nan", "finite"},
    {"unknown tag", 12, "EDGE_SE2_BOGUS 2 3 1 0 0 100 0 0 100 0 400", "EDGE_SE2_BOGUS"},
    {"information not positive definite", 11, "EDGE_SE2 1 2 0.98 -0.01 -0.02 100 0 0 -100 0 400",
     "positive definite"},
    {"edge to an undefined vertex", 13, "EDGE_SE2 3 99 0.99 0.02 -0.01 100 0 0 100 0 400",
     "99"},
    {"pose not connected to the anchor", 24, "VERTEX_SE2 7 10 10 0", "not connected"},
};

TEST_F(SolveCommandTest, BadInputReturnsTwoNamesTheLineAndWritesNothing) {
  for (const BadInputCase& bad : kBadInputCases) {
    SCOPED_TRACE(bad.name);
    std::vector<std::string> lines = SmallProblemLines();
    if (bad.line <= static_cast<int>(lines.size())) {
      lines[bad.line - 1] = bad.content;
    } else {
      ASSERT_EQ(bad.line, static_cast<int>(lines.size()) + 1);
      lines.push_back(bad.content);
    }
    const std::string input = WriteLines("in.g2o", lines);
    const auto [code, message] = RunCapturingStderr(AllOutputs(input));
    EXPECT_EQ(code, kExitBadInput) << message;
    EXPECT_THAT(message, HasSubstr("in.g2o:" + std::to_string(bad.line) + ":"));
    EXPECT_THAT(message, HasSubstr(bad.expected));
    // Only the input is left: no output, no report, no "*.tmp-*".
    EXPECT_THAT(Files(), ::testing::ElementsAre("in.g2o")) << message;
  }
}

TEST_F(SolveCommandTest, UsageErrorsReturnOneAndWriteNothing) {
  const std::string input = WriteLines("in.g2o", SmallProblemLines());
  struct UsageCase {
    const char* name;
    void (*apply)(SolveCommandOptions*);
    const char* expected;
  };
  const UsageCase cases[] = {
      {"--solver foo", [](SolveCommandOptions* o) { o->solver = "foo"; }, "--solver"},
      {"--max-iterations -1", [](SolveCommandOptions* o) { o->max_iterations = -1; },
       "--max-iterations"},
      {"--robust-kernel bogus", [](SolveCommandOptions* o) { o->robust_kernel = "bogus"; },
       "--robust-kernel"},
      {"--pcg-eta-min 0", [](SolveCommandOptions* o) { o->pcg_eta_min = 0.0; }, "--pcg-eta-min"},
      {"--pcg-eta-min above --pcg-eta-max",
       [](SolveCommandOptions* o) {
         o->pcg_eta_max = 0.01;
         o->pcg_eta_min = 0.1;
       },
       "--pcg-eta-min"},
      {"--initialization bogus", [](SolveCommandOptions* o) { o->initialization = "bogus"; },
       "--initialization"},
  };
  for (const UsageCase& usage : cases) {
    SCOPED_TRACE(usage.name);
    SolveCommandOptions options = AllOutputs(input);
    usage.apply(&options);
    const auto [code, message] = RunCapturingStderr(options);
    EXPECT_EQ(code, kExitUsage) << message;
    EXPECT_THAT(message, HasSubstr(usage.expected));
    EXPECT_THAT(Files(), ::testing::ElementsAre("in.g2o"));
  }
}

TEST_F(SolveCommandTest, FailedSolveLeavesPreviousOutputsByteIdentical) {
  const std::string input = WriteLines("in.g2o", SmallProblemLines());
  const SolveCommandOptions options = AllOutputs(input);
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  std::map<std::string, std::string> before;
  for (const std::string& path :
       {options.output_g2o, options.report, options.tum, options.features_csv}) {
    before[path] = ReadBytes(path);
    ASSERT_FALSE(before[path].empty()) << path;
  }
  const std::vector<std::string> files_before = Files();

  std::vector<std::string> lines = SmallProblemLines();
  lines[15 - 1] = "EDGE_SE2_XY 1 10 0.02 oops 100 0 100";
  WriteLines("in.g2o", lines);
  const auto [code, message] = RunCapturingStderr(options);
  EXPECT_EQ(code, kExitBadInput) << message;
  EXPECT_THAT(message, HasSubstr("in.g2o:15:"));
  for (const auto& [path, bytes] : before) {
    EXPECT_EQ(ReadBytes(path), bytes) << path << " changed";
  }
  EXPECT_EQ(Files(), files_before);
}

TEST_F(SolveCommandTest, IterationLimitReturnsFourButWritesOutputs) {
  const std::string input = WriteLines("in.g2o", SmallProblemLines());
  SolveCommandOptions options = AllOutputs(input);
  options.max_iterations = 1;
  // From dead reckoning: the default initialization solves this problem
  // before the optimization starts, so one iteration would converge.
  options.initialization = "odometry";
  ASSERT_EQ(RunSolveCommand(options), kExitNotConverged);
  for (const std::string& path :
       {options.output_g2o, options.report, options.tum, options.features_csv}) {
    EXPECT_TRUE(std::filesystem::exists(path)) << path;
  }
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["iterations"].get<int>(), 1);
  EXPECT_FALSE(report["converged"].get<bool>());
  EXPECT_LE(report["final_chi2"].get<double>(), report["initial_chi2"].get<double>());
  StatusOr<core::Problem2d> written = storage::ReadG2o(options.output_g2o);
  ASSERT_TRUE(written.ok()) << written.status().ToString();
  EXPECT_EQ(written->num_poses(), kSmallPoses);
}

TEST_F(SolveCommandTest, VictoriaParkRunsTwoIterations) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  SolveCommandOptions options;
  options.input = ::graphslam::testing::DatasetPath("victoria_park/victoriaPark-full.g2o");
  options.report = Path("report.json");
  options.max_iterations = 2;
  options.quiet = true;
  const int code = RunSolveCommand(options);
  EXPECT_TRUE(code == kExitOk || code == kExitNotConverged) << code;
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["poses"].get<int>(), 6969);
  EXPECT_EQ(report["features"].get<int>(), 151);
  EXPECT_EQ(report["observations"].get<int>(), 3640);
  EXPECT_LE(report["iterations"].get<int>(), 2);
  EXPECT_LE(report["final_chi2"].get<double>(), report["initial_chi2"].get<double>());
}

// Solves MRCLAM dataset 1 (robot 1) and measures the result against Vicon.
class MrclamSolveTest : public SolveCommandTest {
 protected:
  struct Errors {
    TrajectoryErrors trajectory;
    FeatureErrors features;             // against the map with 11 and 17 swapped
    FeatureErrors features_as_surveyed;  // against Landmark_Groundtruth.dat as it is
  };

  // Solves with `max_iterations` (0: the Table 1 initialization, i.e. dead
  // reckoning) and compares the --tum / --features-csv outputs with the
  // ground truth (landmarks 11 and 17 swapped, see below).
  Errors SolveAndCompare(const std::string& folder, int max_iterations) {
    SolveCommandOptions options;
    options.input = folder;
    options.robot = 1;
    options.robust_kernel = "cauchy:1";
    // The paper's initialization (dead reckoning, Table 1): MRCLAM converges
    // from it, and progressive initialization of 75 000 poses takes ~10x longer.
    options.initialization = "odometry";
    options.max_iterations = max_iterations;
    options.tum = Path("robot1.tum");
    options.features_csv = Path("robot1_features.csv");
    options.quiet = true;
    const int code = RunSolveCommand(options);
    EXPECT_TRUE(code == kExitOk || code == kExitNotConverged) << code;

    StatusOr<storage::MrclamGroundTruth> truth = storage::ReadMrclamGroundTruth(folder, 1);
    EXPECT_TRUE(truth.ok()) << truth.status().ToString();
    if (!truth.ok()) return {};
    std::vector<StampedPose2> true_poses(truth->stamps.size());
    for (size_t i = 0; i < truth->stamps.size(); ++i)
      true_poses[i] = {truth->stamps[i], truth->poses[i]};
    // The dataset's barcodes of landmarks 11 and 17 are swapped relative to
    // Landmark_Groundtruth.dat: every measurement of either disagrees with the
    // surveyed position at the Vicon poses and agrees once the two are
    // exchanged. Swap them in the ground truth map, not in the solve.
    std::map<int64_t, core::Point2> true_landmarks = truth->landmarks;
    EXPECT_EQ(true_landmarks.count(11), 1u);
    EXPECT_EQ(true_landmarks.count(17), 1u);
    std::swap(true_landmarks[11], true_landmarks[17]);

    StatusOr<std::vector<StampedPose2>> estimated = ReadTum(options.tum);
    EXPECT_TRUE(estimated.ok()) << estimated.status().ToString();
    StatusOr<std::map<int64_t, core::Point2>> features = ReadFeaturesCsv(options.features_csv);
    EXPECT_TRUE(features.ok()) << features.status().ToString();
    if (!estimated.ok() || !features.ok()) return {};
    StatusOr<TrajectoryErrors> trajectory = CompareTrajectories(*estimated, true_poses);
    EXPECT_TRUE(trajectory.ok()) << trajectory.status().ToString();
    if (!trajectory.ok()) return {};
    Errors errors;
    errors.trajectory = *trajectory;
    errors.features = CompareFeatures(*features, true_landmarks, trajectory->alignment);
    errors.features_as_surveyed =
        CompareFeatures(*features, truth->landmarks, trajectory->alignment);
    return errors;
  }
};

TEST_F(MrclamSolveTest, Dataset1RobotOneMatchesViconFarBetterThanOdometry) {
  GS_REQUIRE_DATASET("mrclam_dataset1_sampled50hz/Robot1_Odometry.dat");
  const std::string folder = ::graphslam::testing::DatasetPath("mrclam_dataset1_sampled50hz");

  const Errors odometry = SolveAndCompare(folder, /*max_iterations=*/0);
  const Errors solved = SolveAndCompare(folder, /*max_iterations=*/100);
  ASSERT_FALSE(HasFailure());

  EXPECT_GT(solved.trajectory.matched, 1000);
  EXPECT_EQ(solved.trajectory.matched, odometry.trajectory.matched);
  EXPECT_GT(odometry.trajectory.position_rmse, 1.0) << "dead reckoning should drift";
  EXPECT_LT(solved.trajectory.position_rmse, 0.2);
  EXPECT_LT(solved.trajectory.heading_rmse_rad, 0.1);
  EXPECT_LT(solved.trajectory.position_rmse, 0.2 * odometry.trajectory.position_rmse);
  EXPECT_EQ(solved.features.matched, 15);
  EXPECT_LT(solved.features.rmse_trajectory_aligned, 0.2);
  EXPECT_LT(solved.features.rmse_self_aligned, 0.2);
  // The swap is what the data say, not a fudge: without it the two landmarks
  // sit where the other one was surveyed.
  EXPECT_GT(solved.features_as_surveyed.rmse_trajectory_aligned,
            2.0 * solved.features.rmse_trajectory_aligned);
}

// Robot 3 of the published dataset 1 has barcode 43, in no row of
// Barcodes.dat, twice: the solve goes on and its report counts them and names
// their lines.
TEST_F(MrclamSolveTest, Dataset1RobotThreeReportsItsUnknownBarcodes) {
  GS_REQUIRE_DATASET("mrclam_dataset1_sampled50hz/Robot3_Measurement.dat");
  SolveCommandOptions options;
  options.input = ::graphslam::testing::DatasetPath("mrclam_dataset1_sampled50hz");
  options.robot = 3;
  options.initialization = "odometry";
  options.max_iterations = 0;
  options.report = Path("robot3.json");
  options.quiet = true;
  const int code = RunSolveCommand(options);
  EXPECT_TRUE(code == kExitOk || code == kExitNotConverged) << code;
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["mrclam"]["unknown_barcodes_skipped"].get<int>(), 2);
  EXPECT_EQ(report["mrclam"]["unknown_barcode_lines"],
            nlohmann::json({"Robot3_Measurement.dat:4938: 942.52 43 1.992 -0.287",
                            "Robot3_Measurement.dat:4943: 943.22 43 1.953 -0.293"}));
  EXPECT_EQ(report["mrclam"]["robot_measurements_dropped"].get<int>(), 1969);
}

// --repair-information: the default still rejects a non-PD information naming
// the line; with the flag the solve runs, and the report and summary count it.
TEST_F(SolveCommandTest, RepairInformationIsOptInAndCounted) {
  std::vector<std::string> lines = SmallProblemLines();
  lines[10] = "EDGE_SE2 1 2 0.98 -0.01 -0.02 100 0 0 -100 0 400";  // line 11: indefinite
  const std::string input = WriteLines("in.g2o", lines);
  const auto [code, message] = RunCapturingStderr(AllOutputs(input));
  EXPECT_EQ(code, kExitBadInput) << message;
  EXPECT_THAT(message, HasSubstr("in.g2o:11: EDGE_SE2 information"));
  SolveCommandOptions options = AllOutputs(input);
  options.repair_information = true;
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["information_repairs"]["repaired"].get<int64_t>(), 1);
  EXPECT_EQ(report["information_repairs"]["first_lines"], nlohmann::json({11}));
  options.quiet = false;
  ::testing::internal::CaptureStdout();
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  EXPECT_THAT(::testing::internal::GetCapturedStdout(),
              HasSubstr("information        1 matrices were not positive definite: repaired"));
}

// The same for a 3-D g2o file: a three-pose chain whose loop edge (line 7)
// has information diag(1, 1, 1, 1, 1, -1).
TEST_F(SolveCommandTest, RepairInformationCoversThreeDimensionalFiles) {
  const std::string identity = "1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1";
  const std::string input = WriteLines(
      "in3.g2o", {"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1", "VERTEX_SE3:QUAT 1 1.1 0 0 0 0 0 1",
                  "VERTEX_SE3:QUAT 2 1.9 0.1 0 0 0 0 1", "FIX 0",
                  "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 " + identity,
                  "EDGE_SE3:QUAT 1 2 1 0 0 0 0 0 1 " + identity,
                  "EDGE_SE3:QUAT 0 2 2 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 -1"});
  SolveCommandOptions options = AllOutputs(input);
  const auto [code, message] = RunCapturingStderr(options);
  EXPECT_EQ(code, kExitBadInput) << message;
  EXPECT_THAT(message, HasSubstr("in3.g2o:7: EDGE_SE3:QUAT information"));
  options.repair_information = true;
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["dimension"].get<int>(), 3);
  EXPECT_EQ(report["information_repairs"]["repaired"].get<int64_t>(), 1);
  EXPECT_EQ(report["information_repairs"]["first_lines"], nlohmann::json({7}));
  EXPECT_LT(report["final_chi2"].get<double>(), 1e-9);  // the three edges agree
  options.quiet = false;
  ::testing::internal::CaptureStdout();
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  EXPECT_THAT(::testing::internal::GetCapturedStdout(),
              HasSubstr("information        1 matrices were not positive definite: repaired"));
}

// 3-D --features-csv: noise-free point observations from a chain of three
// poses (x_i = (i, 0, 0), no rotation, pose 0 fixed); the points start up to
// 0.4 m off and the CSV holds them at the optimum, their true positions.
TEST_F(SolveCommandTest, ThreeDimensionalFeaturesCsvHoldsTheSolvedPoints) {
  const std::string pose_information = " 100 0 0 0 0 0 100 0 0 0 0 100 0 0 0 100 0 0 100 0 100";
  const std::string point_information = " 10 0 0 10 0 10";
  std::vector<std::string> lines = {
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1", "VERTEX_SE3:QUAT 1 1 0 0 0 0 0 1",
      "VERTEX_SE3:QUAT 2 2 0 0 0 0 0 1", "VERTEX_TRACKXYZ 10 1.3 2.4 0.1",
      "VERTEX_TRACKXYZ 11 2.4 -1.2 1.4", "FIX 0", "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1",
      "EDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1" + pose_information,
      "EDGE_SE3:QUAT 1 2 1 0 0 0 0 0 1" + pose_information};
  const double points[2][3] = {{1, 2, 0.5}, {2, -1, 1}};
  for (int k = 0; k < 2; ++k)
    for (int i = 0; i < 3; ++i)
      lines.push_back("EDGE_SE3_TRACKXYZ " + std::to_string(i) + " " + std::to_string(10 + k) +
                      " 0 " + std::to_string(points[k][0] - i) + " " +
                      std::to_string(points[k][1]) + " " + std::to_string(points[k][2]) +
                      point_information);
  const SolveCommandOptions options = AllOutputs(WriteLines("points3.g2o", lines));
  const auto [code, message] = RunCapturingStderr(options);
  ASSERT_EQ(code, kExitOk) << message;
  std::ifstream csv(options.features_csv);
  std::string line;
  ASSERT_TRUE(std::getline(csv, line));
  EXPECT_EQ(line, "id,x,y,z,observations,excluded");
  for (int k = 0; k < 2; ++k) {
    ASSERT_TRUE(std::getline(csv, line));
    long long id = 0, observations = 0, excluded = 1;
    double x[3];
    ASSERT_EQ(std::sscanf(line.c_str(), "%lld,%lf,%lf,%lf,%lld,%lld", &id, &x[0], &x[1], &x[2],
                          &observations, &excluded),
              6)
        << line;
    EXPECT_EQ(id, 10 + k);
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(x[d], points[k][d], 1e-6) << line;
    EXPECT_EQ(observations, 3);
    EXPECT_EQ(excluded, 0);
  }
  EXPECT_FALSE(std::getline(csv, line));

  // The written graph opens with PARAMS_SE3OFFSET; solve must read it back
  // and find it already at the optimum.
  SolveCommandOptions again;
  again.input = options.output_g2o;
  again.report = Path("report_again.json");
  again.quiet = true;
  const auto [code_again, message_again] = RunCapturingStderr(again);
  ASSERT_EQ(code_again, kExitOk) << message_again;
  const nlohmann::json report = ReadJson(again.report);
  EXPECT_EQ(report["dimension"].get<int>(), 3);
  EXPECT_LT(report["final_chi2"].get<double>(), 1e-9);
}

}  // namespace
}  // namespace graphslam::tools
