// `graphslam solve --initialization` end to end (tools/solve_command.h), for
// the modes perf/solver_comparison.py --start relies on to give every solver
// the same start:
//   as-given    the input's guess unchanged (every vertex must have one);
//   pose-graph  Table 1, then the pose-only problem solved and the features
//               re-placed (partition/initialization/pose_graph_initialization.h), in memory;
//   a start written with --max-iterations 0 -o reloads to the same chi2, and
//   solving from it gives the same optimum as solving directly.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "storage/g2o_reader.h"
#include "tests/testing/dense_campus_store.h"
#include "tools/exit_codes.h"
#include "tools/ingest_command.h"
#include "tools/simulate_command.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

class SolveInitializationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = fs::temp_directory_path() /
            ("graphslam_solve_init_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  std::string Path(const std::string& name) const { return (root_ / name).string(); }

  std::string WriteLines(const std::string& name, const std::vector<std::string>& lines) const {
    std::ofstream out(Path(name));
    for (const std::string& line : lines) out << line << "\n";
    return Path(name);
  }

  // A 600-pose GPS campus as g2o (range-bearing -> EDGE_SE2_XY), with the
  // control noise of the sim1e5 benchmark problem.
  std::string SimulatedCampus() const {
    SimulateCommandOptions options;
    options.output_dir = Path("sim");
    options.format = "g2o";
    options.simulator.poses = 600;
    options.simulator.features = 600;
    options.simulator.gps_every = 25;
    options.alpha = {1e-4, 1e-5, 3e-7, 1e-4, 3e-7, 1e-4};
    options.quiet = true;
    EXPECT_EQ(RunSimulateCommand(options), kExitOk);
    return Path("sim/graph.g2o");
  }

  SolveCommandOptions Solve(const std::string& input, const std::string& initialization,
                            int max_iterations, const std::string& report) const {
    SolveCommandOptions options;
    options.input = input;
    options.initialization = initialization;
    options.max_iterations = max_iterations;
    options.report = Path(report);
    options.threads = 1;
    options.quiet = true;
    return options;
  }

  static nlohmann::json ReadJson(const std::string& path) {
    std::ifstream in(path);
    return nlohmann::json::parse(in);
  }

  fs::path root_;
};

// Vertex values the Table 1 initialization would not produce (pose 2 is not
// pose 1 (+) odometry, the feature is not where its first observation puts it):
// as-given must keep them bit for bit.
TEST_F(SolveInitializationTest, AsGivenLeavesTheInputGuessUntouched) {
  const std::string input = WriteLines(
      "in.g2o", {"VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 1.25 0.375 0.125",
                 "VERTEX_SE2 2 2.5 -0.625 -0.25", "VERTEX_XY 10 1.75 2.5",
                 "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 400", "EDGE_SE2 1 2 1 0 0 100 0 0 100 0 400",
                 "EDGE_SE2_XY 0 10 1 2 100 0 100", "EDGE_SE2_XY 1 10 0 2 100 0 100",
                 "EDGE_SE2_XY 2 10 -1 2 100 0 100"});
  SolveCommandOptions options = Solve(input, "as-given", 0, "report.json");
  options.output_g2o = Path("out.g2o");
  ASSERT_EQ(RunSolveCommand(options), kExitNotConverged);  // 0 iterations: not converged
  StatusOr<core::Problem2d> in = storage::ReadG2o(input);
  StatusOr<core::Problem2d> out = storage::ReadG2o(options.output_g2o);
  ASSERT_TRUE(in.ok() && out.ok());
  ASSERT_EQ(out->num_poses(), 3);
  ASSERT_EQ(out->num_features(), 1);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(out->poses[i], in->poses[i]) << "pose " << i;
  EXPECT_EQ(out->features[0], in->features[0]);
  // chi2 of the guess: pose 1 is (0.25, 0.375, 0.125) off its odometry, so
  // the guess is not at the optimum (a check that the chi2 is of this guess).
  EXPECT_GT(ReadJson(options.report)["initial_chi2"].get<double>(), 10.0);

  // An edges-only file (no VERTEX lines: the reader creates the vertices
  // without a guess): Table 1 fills them in (odometry mode), as-given refuses
  // and names the first, writing nothing.
  const std::string partial =
      WriteLines("partial.g2o", {"EDGE_SE2 0 1 1 0 0 100 0 0 100 0 400",
                                 "EDGE_SE2 1 2 1 0 0 100 0 0 100 0 400"});
  EXPECT_EQ(RunSolveCommand(Solve(partial, "odometry", 0, "odometry.json")), kExitNotConverged);
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RunSolveCommand(Solve(partial, "as-given", 0, "as_given.json")), kExitBadInput);
  const std::string error = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(error.find("pose 0 has no initial guess"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(Path("as_given.json")));
}

TEST_F(SolveInitializationTest, UnknownInitializationIsAUsageError) {
  const std::string input = WriteLines("in.g2o", {"VERTEX_SE2 0 0 0 0", "VERTEX_SE2 1 1 0 0",
                                                  "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 400"});
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RunSolveCommand(Solve(input, "given", 0, "report.json")), kExitUsage);
  const std::string error = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(error.find("as-given"), std::string::npos) << error;
}

// The benchmark's --start: the written start reloads (as-given) to the chi2
// it was written with, and the solve from it reaches the optimum of the
// direct solve (progressive initialization + LM in one process).
TEST_F(SolveInitializationTest, WrittenStartReloadsToTheSameChi2AndOptimum) {
  const std::string campus = SimulatedCampus();
  SolveCommandOptions write = Solve(campus, "progressive", 0, "start.json");
  write.output_g2o = Path("start.g2o");
  ASSERT_EQ(RunSolveCommand(write), kExitNotConverged);
  const double start_chi2 = ReadJson(write.report)["final_chi2"].get<double>();

  ASSERT_EQ(RunSolveCommand(Solve(write.output_g2o, "as-given", 0, "reload.json")),
            kExitNotConverged);
  EXPECT_NEAR(ReadJson(Path("reload.json"))["initial_chi2"].get<double>(), start_chi2,
              1e-12 * start_chi2);

  ASSERT_EQ(RunSolveCommand(Solve(write.output_g2o, "as-given", 100, "from_start.json")),
            kExitOk);
  ASSERT_EQ(RunSolveCommand(Solve(campus, "progressive", 100, "direct.json")), kExitOk);
  const double from_start = ReadJson(Path("from_start.json"))["final_chi2"].get<double>();
  const double direct = ReadJson(Path("direct.json"))["final_chi2"].get<double>();
  EXPECT_NEAR(from_start, direct, 1e-9 * direct);
  EXPECT_LT(from_start, 0.5 * start_chi2);
}

// pose-graph in memory: the GPS pulls the dead-reckoned trajectory onto the
// fixes, so its guess costs less than Table 1's (1/4.6 here), and LM from it reaches
// the noise floor (chi2 per degree of freedom near 1).
TEST_F(SolveInitializationTest, PoseGraphStartBeatsOdometryAndReachesTheNoiseFloor) {
  const std::string campus = SimulatedCampus();
  ASSERT_EQ(RunSolveCommand(Solve(campus, "odometry", 0, "odometry.json")), kExitNotConverged);
  ASSERT_EQ(RunSolveCommand(Solve(campus, "pose-graph", 0, "pose_graph.json")),
            kExitNotConverged);
  const double odometry = ReadJson(Path("odometry.json"))["final_chi2"].get<double>();
  const double pose_graph = ReadJson(Path("pose_graph.json"))["final_chi2"].get<double>();
  EXPECT_LT(pose_graph, 0.5 * odometry) << "odometry " << odometry;

  ASSERT_EQ(RunSolveCommand(Solve(campus, "pose-graph", 100, "solved.json")), kExitOk);
  const nlohmann::json report = ReadJson(Path("solved.json"));
  const double dof = report["residual_dimension"].get<double>() - report["unknowns"].get<double>();
  const double per_dof = report["final_chi2"].get<double>() / dof;
  EXPECT_GT(per_dof, 0.8) << report["final_chi2"];
  EXPECT_LT(per_dof, 1.2) << report["final_chi2"];
  EXPECT_GE(report["optimize_cpu_seconds"].get<double>(), 0.0);
}

// --pcg-eta-min floors the forcing sequence (the Eisenstat-Walker term
// tightens as the gradient falls). On this campus with --pcg-eta-max 0.1 the
// sequence goes below 0.1 from the second iteration on; a floor at 0.1 (a
// constant forcing term) saves CG iterations, and LM still stops at CHOLMOD's
// optimum.
TEST_F(SolveInitializationTest, PcgEtaMinCapsTheLastSolvesAtTheSameOptimum) {
  const std::string campus = SimulatedCampus();
  auto run = [&](const std::string& solver, double eta_min, const std::string& report) {
    SolveCommandOptions options = Solve(campus, "pose-graph", 100, report);
    options.solver = solver;
    options.pcg_eta_max = 0.1;
    options.pcg_eta_min = eta_min;
    EXPECT_EQ(RunSolveCommand(options), kExitOk) << report;
    return ReadJson(Path(report));
  };
  const nlohmann::json cholmod = run("cholmod", 1e-10, "cholmod.json");
  const nlohmann::json tight = run("pcg", 1e-10, "tight.json");
  const nlohmann::json floored = run("pcg", 0.1, "floored.json");
  auto cg = [](const nlohmann::json& report) {
    int total = 0;
    for (const nlohmann::json& it : report["per_iteration"])
      total += it["linear_solver_iterations"].get<int>();
    return total;
  };
  EXPECT_LT(cg(floored), cg(tight));
  EXPECT_DOUBLE_EQ(floored["pcg_eta_min"].get<double>(), 0.1);
  const double optimum = cholmod["final_chi2"].get<double>();
  EXPECT_NEAR(tight["final_chi2"].get<double>(), optimum, 1e-6 * optimum);
  EXPECT_NEAR(floored["final_chi2"].get<double>(), optimum, 1e-6 * optimum);
}

// `graphslam benchmark`'s proportion at small sizes (0.01 poses per feature,
// GPS every 50 poses, landmarks 0.015-0.025 m apart, 8 m sensor range): the
// stream simulated, ingested into a store and solved with default options
// reaches the optimum, chi2 per degree of freedom about 1 (the simulated
// noise is the modelled one; the deviation is noise, sqrt(2 / dof) ~ 0.015
// here). Chained odometry drifts fast on these campuses: an initialization
// stage that starts its new poses outside the basin used to settle in a local
// minimum (one run of 500 poses: 6.2; two runs of 50: 1.67). At 10^5
// features (346 observations per pose, the density of every larger size)
// the stages are bounded by observations and their new poses localized from
// the features they share with the poses before: chi2/dof within 1 %. The
// 10^6-feature campus (1 000 poses, 362 observations per pose) has stretches
// where a pose sees no features: a pose after one shares a few features
// bunched in one spot with the poses before, which do not pin its heading
// (localized from them it was 2 rad off, and the start ended at 8.5), and a
// pose re-entering a street seen before must be localized from the features
// solved then, not from those placed from the poses chained since (1.056).
TEST_F(SolveInitializationTest, DefaultsReachTheOptimumOfSmallGpsCampusStores) {
  struct Campus {
    int64_t poses;
    int runs;
    int64_t features;
    double tolerance;  // on chi2/dof
  };
  for (const Campus campus : {Campus{500, 1, 10000, 0.03}, Campus{100, 2, 10000, 0.03},
                              Campus{1000, 2, 100000, 0.01}, Campus{1000, 2, 1000000, 0.01}}) {
    const std::string name = std::to_string(campus.poses) + "x" + std::to_string(campus.runs) +
                             "_" + std::to_string(campus.features);
    SCOPED_TRACE(name);
    const std::string store = testing::SimulateDenseCampusStore(
        Path(""), name, campus.poses, campus.runs, campus.features);
    ASSERT_FALSE(store.empty());
    SolveCommandOptions options;
    options.input = store;
    options.report = Path(name + ".json");
    options.quiet = true;
    ASSERT_EQ(RunSolveCommand(options), kExitOk);
    const nlohmann::json report = ReadJson(options.report);
    EXPECT_EQ(report["initialization_used"].get<std::string>(), "incremental");
    const double dof =
        report["residual_dimension"].get<double>() - report["unknowns"].get<double>();
    ASSERT_GT(dof, 1000.0);
    EXPECT_NEAR(report["final_chi2"].get<double>() / dof, 1.0, campus.tolerance);
  }
}

// A store solved in streaming mode (here forced by --streaming-poses 0; by
// default a store above 10^5 poses) starts from incremental initialization
// of a feature sample (partition/initialization/sampled_incremental_initialization.h;
// this store is within the sample's budget, so sampled whole). The
// pose-graph start it replaces ends this campus in a local minimum (poses
// drifted between GPS fixes place their features wrong).
TEST_F(SolveInitializationTest, StreamingDefaultsReachTheOptimumOfADenseCampusStore) {
  const std::string store = testing::SimulateDenseCampusStore(Path(""), "", 1000, 2, 1000000);
  ASSERT_FALSE(store.empty());
  SolveCommandOptions options;
  options.input = store;
  options.report = Path("report.json");
  options.streaming_poses = 0;
  options.quiet = true;
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  const nlohmann::json report = ReadJson(options.report);
  EXPECT_EQ(report["initialization_used"].get<std::string>(), "sampled-incremental");
  EXPECT_EQ(report["sampled_incremental_initialization"]["rate"].get<double>(), 1.0);
  const double dof =
      report["residual_dimension"].get<double>() - report["unknowns"].get<double>();
  ASSERT_GT(dof, 100000.0);
  EXPECT_NEAR(report["final_chi2"].get<double>() / dof, 1.0, 0.01);
}

// A store below the streaming thresholds but above the sample budget B is
// solved in streaming mode from the sampled start (there the sample is a
// part of the observations, where the in-memory start would take them
// all); within B its observations are loaded into memory. B is set here by
// --sample-observations (by default max(10^6, 24 x poses)).
TEST_F(SolveInitializationTest, StoreAboveTheSampleBudgetStreams) {
  const std::string store = testing::SimulateDenseCampusStore(Path(""), "", 200, 2, 100000);
  ASSERT_FALSE(store.empty());
  const auto solve = [&](const std::string& name, int64_t sample) {
    SolveCommandOptions options;
    options.input = store;
    options.report = Path(name + ".json");
    options.max_iterations = 0;
    options.sample_observations = sample;
    options.quiet = true;
    // No iteration: "not converged" (exit 4), the report written.
    EXPECT_EQ(RunSolveCommand(options), kExitNotConverged);
    return ReadJson(options.report);
  };
  const nlohmann::json whole = solve("whole", 0);
  const int64_t observations = whole["observations"].get<int64_t>();
  ASSERT_GT(observations, 1000);
  ASSERT_LT(observations, 1000000);  // within the default B: in memory
  EXPECT_FALSE(whole["streaming"].get<bool>());
  EXPECT_EQ(whole["initialization_used"].get<std::string>(), "incremental");

  const nlohmann::json at_budget = solve("at_budget", observations);
  EXPECT_FALSE(at_budget["streaming"].get<bool>());

  const nlohmann::json above = solve("above", observations - 1);
  EXPECT_TRUE(above["streaming"].get<bool>());
  EXPECT_EQ(above["initialization_used"].get<std::string>(), "sampled-incremental");
  EXPECT_LT(above["sampled_incremental_initialization"]["rate"].get<double>(), 1.0);
}

// --sample-observations sets the start's sample budget B; --memory-limit caps
// it at what one chunk in flight leaves (300 B per observation), and the
// report says so. Only the start is looked at (--max-iterations 0).
TEST_F(SolveInitializationTest, SampleBudgetFollowsTheOptionAndTheMemoryLimit) {
  const std::string store = testing::SimulateDenseCampusStore(Path(""), "", 1000, 2, 1000000);
  ASSERT_FALSE(store.empty());
  const auto start = [&](const std::string& name, int64_t sample, const std::string& limit) {
    SolveCommandOptions options;
    options.input = store;
    options.report = Path(name + ".json");
    options.streaming_poses = 0;
    options.max_iterations = 0;
    options.sample_observations = sample;
    options.memory_limit = limit;
    options.quiet = true;
    // No iteration: "not converged" (exit 4), the report written.
    EXPECT_EQ(RunSolveCommand(options), kExitNotConverged);
    return ReadJson(options.report)["sampled_incremental_initialization"];
  };
  const nlohmann::json rule = start("rule", 0, "");
  // The rule: max(10^6, 24 x 2 000 poses), more than this store holds.
  EXPECT_EQ(rule["budget_observations"].get<int64_t>(), 1000000);
  EXPECT_EQ(rule["rate"].get<double>(), 1.0);
  const int64_t observations = rule["sampled_observations"].get<int64_t>();
  ASSERT_GT(observations, 300000);

  const nlohmann::json option = start("option", 100000, "");
  EXPECT_EQ(option["budget_observations"].get<int64_t>(), 100000);
  EXPECT_FALSE(option["capped_by_memory_limit"].get<bool>());
  EXPECT_NEAR(option["rate"].get<double>(), 100000.0 / static_cast<double>(observations), 1e-12);
  EXPECT_GT(option["sampled_observations"].get<int64_t>(), 80000);
  EXPECT_LT(option["sampled_observations"].get<int64_t>(), 120000);

  const int64_t limit = int64_t{96} << 20;
  const nlohmann::json capped = start("capped", 0, "96M");
  EXPECT_TRUE(capped["capped_by_memory_limit"].get<bool>());
  const int64_t budget = capped["budget_observations"].get<int64_t>();
  EXPECT_GT(budget, 0);
  EXPECT_LT(budget * 300, limit);
  EXPECT_LT(budget, observations);
  EXPECT_LT(capped["sampled_observations"].get<int64_t>(), 1.2 * static_cast<double>(budget));
}

}  // namespace
}  // namespace graphslam::tools
