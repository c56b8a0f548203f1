// The one solve path (tools/pipeline/solve_pipeline.h) end to end: a 2-D and a
// 3-D g2o file go through the same MakeSolveRequest -> RunSolve and reach the
// optima tests/tools/reference_optima_test.cc and reference_optima_3d_test.cc
// assert through `graphslam solve` (../shared/datasets/INDEX.md); a bad input
// ends with its exit code and writes nothing.
#include "tools/pipeline/solve_pipeline.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/testing/datasets.h"
#include "tools/exit_codes.h"
#include "tools/pipeline/solve_request.h"

namespace graphslam::tools {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("graphslam_pipeline_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

struct Outcome {
  int exit_code = -1;
  nlohmann::json report;
};

// Builds the request from `options` (with a report) and runs it.
Outcome RunRequest(SolveCommandOptions options) {
  options.report = TempPath("report.json");
  options.quiet = true;
  StatusOr<SolveRequest> request = MakeSolveRequest(options);
  EXPECT_TRUE(request.ok()) << request.status().ToString();
  if (!request.ok()) return {};
  Outcome run;
  run.exit_code = RunSolve(*request);
  std::ifstream in(options.report);
  if (in) run.report = nlohmann::json::parse(in, nullptr, false);
  std::filesystem::remove(options.report);
  return run;
}

// Within 0.1 % of the reference, or lower.
void ExpectReached(const nlohmann::json& report, double reference) {
  ASSERT_TRUE(report.is_object());
  const double chi2 = report["final_chi2"].get<double>();
  EXPECT_GT(chi2, 0.0);
  EXPECT_LE(chi2, reference * 1.001) << "reference " << reference;
  EXPECT_TRUE(report["converged"].get<bool>());
}

TEST(SolvePipeline, PlanarFileReachesIntelOptimum) {
  GS_REQUIRE_DATASET("freiburg_course_g2o/intel.g2o");
  SolveCommandOptions options;
  options.input = graphslam::testing::DatasetPath("freiburg_course_g2o/intel.g2o");
  const Outcome run = RunRequest(options);
  EXPECT_EQ(run.exit_code, kExitOk);
  ExpectReached(run.report, 359.996112);
  EXPECT_EQ(run.report["format"], "g2o");
  EXPECT_FALSE(run.report.contains("dimension"));  // 2-D reports carry no key
  EXPECT_EQ(run.report["poses"], 1728);
}

TEST(SolvePipeline, SpatialFileReachesParkingGarageOptimum) {
  GS_REQUIRE_DATASET("sesync_posegraphs/parking-garage.g2o");
  SolveCommandOptions options;
  options.input = graphslam::testing::DatasetPath("sesync_posegraphs/parking-garage.g2o");
  options.output_g2o = TempPath("garage.g2o");
  const Outcome run = RunRequest(options);
  EXPECT_EQ(run.exit_code, kExitOk);
  ExpectReached(run.report, 1.238684);
  EXPECT_EQ(run.report["dimension"], 3);
  EXPECT_EQ(run.report["format"], "g2o");
  // The 3-D steps write the same outputs as the 2-D ones.
  EXPECT_GT(std::filesystem::file_size(options.output_g2o), 0u);
  std::filesystem::remove(options.output_g2o);
}

TEST(SolvePipeline, MissingInputIsBadInputAndWritesNothing) {
  SolveCommandOptions options;
  options.input = TempPath("no_such_input.g2o");
  options.output_g2o = TempPath("never.g2o");
  const Outcome run = RunRequest(options);
  EXPECT_EQ(run.exit_code, kExitBadInput);
  EXPECT_FALSE(run.report.is_object());
  EXPECT_FALSE(std::filesystem::exists(options.output_g2o));
}

TEST(SolvePipeline, StoppedAtTheIterationCapWritesOutputsAndSaysSo) {
  GS_REQUIRE_DATASET("sesync_posegraphs/parking-garage.g2o");
  SolveCommandOptions options;
  options.input = graphslam::testing::DatasetPath("sesync_posegraphs/parking-garage.g2o");
  options.max_iterations = 1;
  const Outcome run = RunRequest(options);
  EXPECT_EQ(run.exit_code, kExitNotConverged);
  ASSERT_TRUE(run.report.is_object());
  EXPECT_EQ(run.report["iterations"], 1);
  EXPECT_FALSE(run.report["converged"].get<bool>());
}

}  // namespace
}  // namespace graphslam::tools
