// torus3D (SE-Sync's g2o file, 5000 poses) through `graphslam solve`: the
// solve must end at or below the chi2 g2o's converged LM reports (23008.92,
// ../shared/datasets/INDEX.md). A separate binary because it is the slowest
// 3-D run: with --function-tolerance 1e-2 it stops after 9 iterations at
// chi2 ~20095; the default 1e-6 runs 31 iterations to 19972.26
// (docs/benchmarks.md), i.e. both end BELOW the reference, which the test
// confirms with a chi2 recomputed independently from the written graph.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "storage/g2o_3d_reader.h"
#include "tests/testing/datasets.h"
#include "tests/testing/g2o_edge_se3_chi2.h"
#include "tools/exit_codes.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

TEST(ReferenceOptimaTorus3d, ReachesG2oOptimumOrLower) {
  GS_REQUIRE_DATASET("sesync_posegraphs/torus3D.g2o");
  const std::string stem = (std::filesystem::temp_directory_path() /
                            ("graphslam_torus_" + std::to_string(::getpid())))
                               .string();
  SolveCommandOptions options;
  options.input = graphslam::testing::DatasetPath("sesync_posegraphs/torus3D.g2o");
  options.report = stem + ".json";
  options.output_g2o = stem + ".g2o";
  options.function_tolerance = 1e-2;
  options.quiet = true;
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  std::ifstream in(options.report);
  const nlohmann::json json = nlohmann::json::parse(in, nullptr, false);
  ASSERT_FALSE(json.is_discarded());
  const double chi2 = json["final_chi2"].get<double>();
  EXPECT_TRUE(json["converged"].get<bool>());
  EXPECT_GT(chi2, 0.0);
  EXPECT_LE(chi2, 23008.92 * 1.001);
  StatusOr<core::Problem3d> written = storage::ReadG2o3d(options.output_g2o);
  ASSERT_TRUE(written.ok()) << written.status().ToString();
  EXPECT_NEAR(graphslam::testing::G2oEdgeSe3Chi2(*written), chi2, 1e-6 * chi2);
  std::filesystem::remove(options.report);
  std::filesystem::remove(options.output_g2o);
}

}  // namespace
}  // namespace graphslam::tools
