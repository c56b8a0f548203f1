// Issue 22, defects 5 and 6 at the command level: a command fails before
// any long work when an output cannot be written where it was asked to go
// (tools/output_paths.h); `solve <MRCLAM> -o x.g2o` writes a g2o file
// although landmark ids collide with pose ids (the features are renumbered,
// storage/g2o_writer.h); numbers beyond the read bounds are exit 2 naming
// file:line, never exit 0 on garbage; a numerical failure, which writes
// nothing, is exit 5, not 4 ("outputs written").
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

#include "storage/g2o_reader.h"
#include "storage/mrclam_reader.h"
#include "tests/testing/datasets.h"
#include "tools/exit_codes.h"
#include "tools/output_paths.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class EarlyChecks : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("graphslam_early_checks_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream(Path(name)) << text;
    return Path(name);
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  SolveCommandOptions Solve(const std::string& input) const {
    SolveCommandOptions options;
    options.input = input;
    options.quiet = true;
    options.threads = 1;
    return options;
  }
  fs::path dir_;
};

constexpr const char* kSmall =
    "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.1 0.1 0\nVERTEX_SE2 2 2.1 -0.1 0\nVERTEX_XY 10 1 1\n"
    "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\nEDGE_SE2 1 2 1 0 0 100 0 0 100 0 100\n"
    "EDGE_SE2_XY 0 10 1 1 100 0 100\nEDGE_SE2_XY 1 10 0 1 100 0 100\n";

TEST_F(EarlyChecks, OutputPathRules) {
  EXPECT_TRUE(CheckOutputPaths({{"--report", ""}, {"-o", "-"}, {"--tum", Path("t.tum")}}).ok());
  const Status missing = CheckOutputPaths({{"--report", "/nodir/x.json"}});
  EXPECT_TRUE(missing.IsIOError());
  EXPECT_EQ(missing.message(),
            "--report /nodir/x.json: the folder /nodir does not exist; expected an existing "
            "folder to write the output into");
  const Status folder = CheckOutputPaths({{"-o", dir_.string()}});
  EXPECT_EQ(folder.message(), "-o " + dir_.string() + ": is a folder; expected a file path for "
                                                      "the output");
  const std::string file = Write("plain", "x");
  EXPECT_THAT(CheckOutputPaths({{"--tum", file + "/t.tum"}}).message(),
              HasSubstr("is not a folder"));
  // Folders are created with their parents: the nearest existing ancestor counts.
  EXPECT_TRUE(CheckOutputPaths({{"-o", Path("a/b/c"), /*folder=*/true}}).ok());
  EXPECT_FALSE(CheckOutputPaths({{"-o", file + "/store", /*folder=*/true}}).ok());
}

TEST_F(EarlyChecks, SolveFailsBeforeSolvingWhenAnOutputFolderIsMissing) {
  SolveCommandOptions options = Solve(Write("in.g2o", kSmall));
  options.tum = Path("t.tum");
  options.report = "/nodir/x.json";
  EXPECT_EQ(RunSolveCommand(options), kExitIOError);
  // Nothing was solved or written: the --tum output, written before the
  // report once solved, does not exist.
  EXPECT_FALSE(fs::exists(options.tum));
  options.report.clear();
  options.output_g2o = Path("missing/x.g2o");
  EXPECT_EQ(RunSolveCommand(options), kExitIOError);
  EXPECT_FALSE(fs::exists(options.tum));
}

TEST_F(EarlyChecks, MrclamSolveWritesG2oWithRenumberedFeatures) {
  GS_REQUIRE_DATASET("mrclam_dataset1_sampled50hz/Robot1_Odometry.dat");
  const std::string folder = testing::DatasetPath("mrclam_dataset1_sampled50hz");
  SolveCommandOptions options = Solve(folder);
  options.max_iterations = 0;  // the write is the point, not the optimum
  options.initialization = "odometry";
  options.output_g2o = Path("x.g2o");
  options.report = Path("x.json");
  options.threads = 0;
  ASSERT_EQ(RunSolveCommand(options), kExitNotConverged);  // 0 iterations
  StatusOr<core::Problem2d> mrclam = storage::ReadMrclam(folder, storage::MrclamOptions());
  ASSERT_TRUE(mrclam.ok());
  int64_t largest_pose = 0;
  for (int64_t id : mrclam->pose_ids) largest_pose = std::max(largest_pose, id);
  int64_t smallest_feature = mrclam->feature_ids[0];
  for (int64_t id : mrclam->feature_ids) smallest_feature = std::min(smallest_feature, id);
  const int64_t offset = largest_pose + 1 - smallest_feature;
  const nlohmann::json report = nlohmann::json::parse(Read(options.report));
  EXPECT_EQ(report["g2o_feature_id_offset"].get<int64_t>(), offset);
  const std::string text = Read(options.output_g2o);
  EXPECT_EQ(text.substr(0, text.find('\n')),
            "# graphslam: feature ids renumbered: VERTEX_XY id = feature id + " +
                std::to_string(offset));
  StatusOr<core::Problem2d> back = storage::ReadG2o(options.output_g2o);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->num_poses(), mrclam->num_poses());
  EXPECT_EQ(back->num_features(), mrclam->num_features());
  EXPECT_EQ(back->observations.size(), mrclam->observations.size());
  for (int32_t j = 0; j < back->num_features(); ++j)
    EXPECT_GT(back->feature_ids[j], largest_pose);
}

TEST_F(EarlyChecks, NumbersAtTheEdgeAreBadInputNamingTheLine) {
  const std::string tail =
      "EDGE_SE2 0 1 1 0 0 100 0 0 100 0 100\nEDGE_SE2 1 2 1 0 0 100 0 0 100 0 100\n";
  SolveCommandOptions estimate = Solve(
      Write("estimate.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1e308 0 0\nVERTEX_SE2 2 2 0 0\n" +
                                tail));
  estimate.output_g2o = Path("out.g2o");
  EXPECT_EQ(RunSolveCommand(estimate), kExitBadInput);  // was 4, "initial chi2 is not finite"
  EXPECT_FALSE(fs::exists(estimate.output_g2o));
  SolveCommandOptions information = Solve(Write(
      "information.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n"
                         "EDGE_SE2 0 1 1 0 0 1e308 0 0 1e308 0 1e308\n"
                         "EDGE_SE2 1 2 1 0 0 100 0 0 100 0 100\n"));
  EXPECT_EQ(RunSolveCommand(information), kExitBadInput);  // was 0, chi2 stuck at 4e243
  SolveCommandOptions isam = Solve(Write("m.isam", "ODOMETRY 0 1 1e308 0 0 1 0 0 1 0 1\n"));
  EXPECT_EQ(RunSolveCommand(isam), kExitBadInput);  // was 0, "converged" with x = 1e308
}

TEST(ExitCodes, NumericalFailureIsNotTheOutputsWrittenCode) {
  EXPECT_EQ(ExitCodeFor(Status::Numerical("initial chi2 is not finite")), kExitNumericalFailure);
  EXPECT_NE(kExitNumericalFailure, kExitNotConverged);
  EXPECT_EQ(ExitCodeFor(Status::IOError("x")), kExitIOError);
  EXPECT_EQ(ExitCodeFor(Status::Corruption("x")), kExitBadInput);
}

}  // namespace
}  // namespace graphslam::tools
