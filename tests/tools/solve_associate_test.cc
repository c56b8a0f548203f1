// End-to-end tests of `graphslam solve --associate` (tools/solve_command.h,
// docs/association.md): an id-less g2o file is refused without --associate
// (naming the line, writing nothing) and associated with it: the output has one
// landmark per physical landmark and every observation as an edge to it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "storage/g2o_reader.h"
#include "tools/exit_codes.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

// Five poses along x; landmarks at (1, 2), (3, -2) and (2, 2) (1 m from the
// first), seen without ids: DATA_FEATURE_POINTXY belongs to the pose before it.
// The (pose, landmark) of each observation line is in the comment.
const char* kIdLessProblem =
    "VERTEX_SE2 0 0 0 0\n"
    "FIX 0\n"
    "DATA_FEATURE_POINTXY 0 2 1.01 2.02 100 0 100\n"   // 0 a
    "VERTEX_SE2 1 1.2 0.3 0.2\n"
    "DATA_FEATURE_POINTXY 0 2 0.02 1.98 100 0 100\n"   // 1 a
    "DATA_FEATURE_POINTXY 0 2 0.99 2.02 100 0 100\n"   // 1 c
    "VERTEX_SE2 2 2.3 -0.4 -0.3\n"
    "DATA_FEATURE_POINTXY 0 2 -0.99 2.01 100 0 100\n"  // 2 a
    "DATA_FEATURE_POINTXY 0 2 0.01 1.99 100 0 100\n"   // 2 c
    "DATA_FEATURE_POINTXY 0 2 1.01 -2.01 100 0 100\n"  // 2 b
    "VERTEX_SE2 3 2.6 0.5 0.35\n"
    "DATA_FEATURE_POINTXY 0 2 -1.02 2.0 100 0 100\n"   // 3 c
    "DATA_FEATURE_POINTXY 0 2 0.0 -2.02 100 0 100\n"   // 3 b
    "VERTEX_SE2 4 4.4 -0.5 -0.25\n"
    "DATA_FEATURE_POINTXY 0 2 -1.01 -1.98 100 0 100\n"  // 4 b
    "EDGE_SE2 0 1 1.01 0.02 0.01 100 0 0 100 0 400\n"
    "EDGE_SE2 1 2 0.98 -0.01 -0.02 100 0 0 100 0 400\n"
    "EDGE_SE2 2 3 1.02 0.01 0.015 100 0 0 100 0 400\n"
    "EDGE_SE2 3 4 0.99 0.02 -0.01 100 0 0 100 0 400\n";

class SolveAssociateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("graphslam_solve_associate_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    input_ = (dir_ / "idless.g2o").string();
    std::ofstream(input_) << kIdLessProblem;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::filesystem::path dir_;
  std::string input_;
};

TEST_F(SolveAssociateTest, IdLessInputNeedsAssociate) {
  SolveCommandOptions options;
  options.input = input_;
  options.output_g2o = (dir_ / "out.g2o").string();
  options.quiet = true;
  EXPECT_EQ(RunSolveCommand(options), kExitBadInput);
  EXPECT_FALSE(std::filesystem::exists(options.output_g2o));
}

TEST_F(SolveAssociateTest, AssociatesIdLessObservations) {
  SolveCommandOptions options;
  options.input = input_;
  options.output_g2o = (dir_ / "out.g2o").string();
  options.report = (dir_ / "report.json").string();
  options.associate = true;
  options.association_radius = 3.0;
  options.quiet = true;
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  const auto out = storage::ReadG2o(options.output_g2o);
  ASSERT_TRUE(out.ok()) << out.status().ToString();
  EXPECT_EQ(out->num_features(), 3);
  ASSERT_EQ(out->observations.size(), 9u);
  // Observations in file order: a a c a c b c b b (see kIdLessProblem).
  const int group[9] = {0, 0, 2, 0, 2, 1, 2, 1, 1};
  for (int i = 0; i < 9; ++i) {
    for (int k = 0; k < 9; ++k) {
      EXPECT_EQ(out->observations[i].feature == out->observations[k].feature,
                group[i] == group[k])
          << "observations " << i << " and " << k;
    }
  }
  std::ifstream report_file(options.report);
  const nlohmann::json report = nlohmann::json::parse(report_file);
  ASSERT_TRUE(report.contains("association"));
  EXPECT_EQ(report["association"]["initial_features"], 9);
  EXPECT_EQ(report["association"]["final_features"], 3);
  EXPECT_EQ(report["association"]["merges"], 6);
  ASSERT_FALSE(report["association"]["merge_list"].empty());
  EXPECT_GT(report["association"]["merge_list"][0]["probability"].get<double>(), 1e-3);
}

}  // namespace
}  // namespace graphslam::tools
