// End-to-end tests of `graphslam ingest` (tools/ingest_command.h) and of
// `graphslam solve STORE/`: solving the store gives the same final chi2 (1e-9
// relative) as solving the input directly with the same options; bad options
// and bad input leave no store behind.
#include "tools/ingest_command.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "storage/chunk_store.h"
#include "storage/native_log_reader.h"
#include "tests/testing/datasets.h"
#include "tests/testing/random_problem.h"
#include "tools/exit_codes.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

class IngestCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            ("graphslam_ingest_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  void TearDown() override { std::filesystem::remove_all(root_); }

  std::string Path(const std::string& name) const { return (root_ / name).string(); }

  // A random problem with range-bearing observations, as a native log; with
  // 250 poses progressive initialization solves two stages (100, 200 poses).
  std::string WriteRandomInput(uint32_t seed) const {
    testing::RandomProblemOptions options;
    options.num_poses = 250;
    options.num_features = 40;
    options.seed = seed;
    const std::string path = Path("input.graphslam");
    EXPECT_TRUE(storage::WriteNativeLog(testing::MakeRandomProblem(options).problem, path).ok());
    return path;
  }

  static double FinalChi2(const std::string& report) {
    std::ifstream in(report);
    return nlohmann::json::parse(in).at("final_chi2").get<double>();
  }

  // Solves `input` directly and `store` with otherwise equal options.
  void ExpectSameFinalChi2(const std::string& input, const std::string& store,
                           SolveCommandOptions options) const {
    options.quiet = true;
    options.input = input;
    options.report = Path("direct.json");
    const int direct_code = RunSolveCommand(options);
    ASSERT_TRUE(direct_code == kExitOk || direct_code == kExitNotConverged) << direct_code;
    options.input = store;
    options.report = Path("store.json");
    EXPECT_EQ(RunSolveCommand(options), direct_code);
    const double direct = FinalChi2(Path("direct.json"));
    const double stored = FinalChi2(Path("store.json"));
    EXPECT_LE(std::abs(stored - direct), 1e-9 * std::abs(direct))
        << "store " << stored << " vs direct " << direct;
    std::ifstream in(Path("store.json"));
    EXPECT_EQ(nlohmann::json::parse(in).at("format").get<std::string>(), "chunk-store");
  }

  std::filesystem::path root_;
};

TEST_F(IngestCommandTest, SolvingTheStoreEqualsSolvingTheInput) {
  const std::string input = WriteRandomInput(11);
  IngestCommandOptions ingest;
  ingest.input = input;
  ingest.output_dir = Path("store");
  ingest.chunk_observations = 23;
  ingest.compress = true;
  ingest.quiet = true;
  ASSERT_EQ(RunIngestCommand(ingest), kExitOk);
  EXPECT_TRUE(storage::IsChunkStore(ingest.output_dir));
  for (const char* initialization : {"progressive", "odometry"}) {
    SCOPED_TRACE(initialization);
    SolveCommandOptions options;
    options.initialization = initialization;
    options.max_iterations = 20;
    options.chunk_observations = 23;
    ExpectSameFinalChi2(input, ingest.output_dir, options);
  }
}

TEST_F(IngestCommandTest, VictoriaParkStoreSolvesLikeTheInput) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  const std::string input = testing::DatasetPath("victoria_park/victoriaPark-full.g2o");
  IngestCommandOptions ingest;
  ingest.input = input;
  ingest.output_dir = Path("store");
  ingest.chunk_observations = 512;
  ingest.quiet = true;
  ASSERT_EQ(RunIngestCommand(ingest), kExitOk);
  SolveCommandOptions options;
  options.initialization = "odometry";
  options.max_iterations = 20;
  options.chunk_observations = 512;
  ExpectSameFinalChi2(input, ingest.output_dir, options);
}

TEST_F(IngestCommandTest, BadOptionsAndBadInputWriteNoStore) {
  IngestCommandOptions ingest;
  ingest.input = WriteRandomInput(12);
  ingest.output_dir = Path("store");
  ingest.quiet = true;
  ingest.chunk_observations = 0;
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RunIngestCommand(ingest), kExitUsage);
  EXPECT_THAT(::testing::internal::GetCapturedStderr(),
              ::testing::HasSubstr("--chunk-observations"));
  EXPECT_FALSE(std::filesystem::exists(ingest.output_dir));

  ingest.chunk_observations = 100;
  ingest.input = Path("missing.g2o");
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RunIngestCommand(ingest), kExitBadInput);
  ::testing::internal::GetCapturedStderr();
  EXPECT_FALSE(std::filesystem::exists(ingest.output_dir));
}

TEST_F(IngestCommandTest, SolveRejectsAStoreWithoutManifest) {
  IngestCommandOptions ingest;
  ingest.input = WriteRandomInput(13);
  ingest.output_dir = Path("store");
  ingest.quiet = true;
  ASSERT_EQ(RunIngestCommand(ingest), kExitOk);
  std::filesystem::remove(std::filesystem::path(ingest.output_dir) / "MANIFEST.json");
  SolveCommandOptions options;
  options.input = ingest.output_dir;
  options.quiet = true;
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(RunSolveCommand(options), kExitBadInput);
  ::testing::internal::GetCapturedStderr();
}

}  // namespace
}  // namespace graphslam::tools
