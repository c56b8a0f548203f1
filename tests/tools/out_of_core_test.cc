// End-to-end tests of the out-of-core command line (docs/out_of_core.md):
// `graphslam solve FILE --workdir DIR` equals the in-memory solve; the
// streaming mode (observations stay on disk, the ingest's Table 1 guess)
// equals the in-memory solve from the same guess; --memory-limit bounds the
// chunks in flight; a streaming solve resumes from a checkpoint whose feature
// estimates are in a binary feature file. (kill -9 during an ingest:
// ingest_kill_test.cc.)
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "tests/testing/directory_bytes.h"
#include "tests/testing/kill_nine.h"
#include "tests/testing/subprocess.h"
#include "tests/tools/out_of_core_fixture.h"

namespace {

namespace fs = std::filesystem;

using graphslam::testing::GraphslamBinary;
using graphslam::testing::RunGraphslam;

using graphslam::testing::ReadJson;

class OutOfCoreTest : public graphslam::testing::OutOfCoreFixture {};

// RunGraphslam with the child's stderr in the file `stderr_path`.
int RunGraphslamRedirected(const std::vector<std::string>& args, const std::string& stderr_path) {
  return graphslam::testing::WaitForExit(
      graphslam::testing::SpawnGraphslamRedirected(args, stderr_path));
}

TEST_F(OutOfCoreTest, WorkdirSolveEqualsInMemorySolve) {
  const std::string input = Simulate(1000, 3);
  ASSERT_EQ(RunGraphslam({"solve", input, "--report", (dir_ / "memory.json").string(),
                          "--chunk-observations", "700", "-q"}),
            0);
  ASSERT_EQ(RunGraphslam({"solve", input, "--workdir", (dir_ / "store").string(), "--report",
                          (dir_ / "store.json").string(), "--chunk-observations", "700",
                          "--memory-limit", "1G", "--threads", "2", "-q"}),
            0);
  const nlohmann::json store = ReadJson(dir_ / "store.json");
  ExpectSameChi2(ReadJson(dir_ / "memory.json"), store);
  EXPECT_EQ(store["format"], "chunk-store");
  EXPECT_FALSE(store["streaming"].get<bool>());
  EXPECT_TRUE(fs::exists(dir_ / "store" / "MANIFEST.json"));
  EXPECT_FALSE(fs::exists(dir_ / "store" / "work")) << "ingest scratch left behind";
  EXPECT_GT(store["peak_rss_bytes"].get<int64_t>(), 0);
}

TEST_F(OutOfCoreTest, StreamingModeEqualsInMemorySolveFromTheSameGuess) {
  // Streaming mode starts from the ingest's Table 1 guess: the in-memory solve
  // with --initialization odometry starts from the same guess.
  const std::string input = Simulate(800, 5);
  ASSERT_EQ(RunGraphslam({"ingest", input, "-o", (dir_ / "store").string(),
                          "--chunk-observations", "300", "--buffer-observations", "1000", "-q"}),
            0);
  ASSERT_EQ(RunGraphslam({"solve", input, "--initialization", "odometry", "--report",
                          (dir_ / "memory.json").string(), "--chunk-observations", "300", "-q"}),
            0);
  for (const char* threads : {"1", "2"}) {
    SCOPED_TRACE(std::string("threads ") + threads);
    ASSERT_EQ(RunGraphslam({"solve", (dir_ / "store").string(), "--streaming-poses", "0",
                            "--initialization", "odometry", "--report",
                            (dir_ / "stream.json").string(), "--threads", threads,
                            "--chunk-observations", "300", "-q"}),
              0);
    const nlohmann::json stream = ReadJson(dir_ / "stream.json");
    EXPECT_TRUE(stream["streaming"].get<bool>());
    ExpectSameChi2(ReadJson(dir_ / "memory.json"), stream);
    fs::remove(dir_ / "store" / "checkpoint.json");
  }
}

TEST_F(OutOfCoreTest, MemoryLimitBoundsChunksInFlightOrIsRejected) {
  const std::string input = Simulate(600, 7);
  // 1 MiB is below the fixed part of the budget (tools/memory_budget.h).
  EXPECT_NE(RunGraphslam({"solve", input, "--workdir", (dir_ / "store").string(),
                          "--memory-limit", "1M", "-q"}),
            0);
  EXPECT_EQ(RunGraphslam({"solve", input, "--memory-limit", "lots", "-q"}), 1);
  // 28 MiB: ~25.4 MiB fixed, pose system and observations in memory (600
  // poses), chunks of 1024 observations 0.5 MiB each: 5 in flight, and too
  // little left for CHOLMOD's factor (4.3 MiB with its indices, S and
  // workspace): --solver cholmod is refused after its analysis.
  EXPECT_EQ(RunGraphslam({"solve", input, "--workdir", (dir_ / "store").string(),
                          "--memory-limit", "28M", "--chunk-observations", "1024", "--solver",
                          "cholmod", "-q"}),
            2);
  ASSERT_EQ(RunGraphslam({"solve", input, "--workdir", (dir_ / "store").string(),
                          "--memory-limit", "28M", "--chunk-observations", "1024", "--solver",
                          "pcg", "--report", (dir_ / "limited.json").string(), "-q"}),
            0);
  const nlohmann::json limited = ReadJson(dir_ / "limited.json");
  EXPECT_GE(limited["chunks_in_flight"].get<int>(), 1);
  EXPECT_LT(limited["chunks_in_flight"].get<int>(), 8);
  // (--solver pcg on both: under a limit `auto` may take PCG. Inexact PCG
  // steps from a store and from memory end within the function tolerance
  // of each other, 1e-6 of chi2, not bit for bit.)
  ASSERT_EQ(RunGraphslam({"solve", input, "--report", (dir_ / "free.json").string(),
                          "--chunk-observations", "1024", "--solver", "pcg", "-q"}),
            0);
  const nlohmann::json free = ReadJson(dir_ / "free.json");
  EXPECT_EQ(free["observations"], limited["observations"]);
  EXPECT_NEAR(limited["final_chi2"].get<double>(), free["final_chi2"].get<double>(),
              1e-6 * free["final_chi2"].get<double>());
}

// Streaming mode keeps a step's candidates in a scratch file beside the
// checkpoint and the checkpoint's feature estimates in a binary feature file
// (no per-feature JSON). A solve stopped after 2 iterations and resumed from
// that checkpoint writes the same -o bytes and chi2 as an uninterrupted one;
// a damaged feature file stops the resume with the file and the offset.
TEST_F(OutOfCoreTest, StreamingResumeFromAFeatureFileEqualsTheUninterruptedSolve) {
  const std::string input = Simulate(700, 9);
  const std::string store = (dir_ / "store").string();
  ASSERT_EQ(RunGraphslam({"ingest", input, "-o", store, "--chunk-observations", "250", "-q"}), 0);
  const auto solve = [&](const std::string& name, const std::string& iterations, bool resume) {
    std::vector<std::string> args = {
        "solve", store, "--streaming-poses", "0", "--initialization", "odometry",
        "--max-iterations", iterations, "--checkpoint", (dir_ / (name + ".json")).string(),
        "-o", (dir_ / (name + ".g2o")).string(), "--report", (dir_ / (name + "_report.json")).string(),
        "--threads", "2", "-q"};
    if (resume) args.push_back("--resume");
    const int code = RunGraphslam(args);
    return code == 0 || code == 4;  // converged, or stopped at --max-iterations
  };
  const auto bytes = [](const fs::path& path) { return graphslam::testing::ReadWholeFile(path); };
  ASSERT_TRUE(solve("full", "5", false));
  ASSERT_TRUE(solve("part", "2", false));
  const nlohmann::json checkpoint = ReadJson(dir_ / "part.json");
  const std::string checkpoint_bytes = bytes(dir_ / "part.json");  // sealed: restored as is
  EXPECT_EQ(checkpoint["version"], 4);
  EXPECT_FALSE(checkpoint.contains("features"));
  EXPECT_EQ(checkpoint["state_file"], "part.json.state.2.bin");
  EXPECT_EQ(checkpoint["features_file"], "part.json.features.2.bin");
  EXPECT_TRUE(fs::exists(dir_ / "part.json.features.2.bin"));
  EXPECT_FALSE(fs::exists(dir_ / "part.json.candidates.bin")) << "scratch file left behind";
  const std::string saved = bytes(dir_ / "part.json.features.2.bin");
  ASSERT_TRUE(solve("part", "5", true));
  const nlohmann::json full = ReadJson(dir_ / "full_report.json");
  const nlohmann::json resumed = ReadJson(dir_ / "part_report.json");
  EXPECT_TRUE(resumed["streaming"].get<bool>());
  EXPECT_EQ(resumed["resumed_from_iteration"].get<int>(), 2);
  EXPECT_EQ(full["final_chi2"].get<double>(), resumed["final_chi2"].get<double>());
  EXPECT_EQ(full["iterations"].get<int>(), resumed["iterations"].get<int>());
  EXPECT_EQ(bytes(dir_ / "full.g2o"), bytes(dir_ / "part.g2o"));

  // Back to the generation-2 checkpoint, with a flipped byte in its feature file.
  fs::remove(dir_ / "part.json.features.5.bin");
  fs::remove(dir_ / "part.json.state.5.bin");
  std::ofstream(dir_ / "part.json", std::ios::binary | std::ios::trunc) << checkpoint_bytes;
  std::string damaged = saved;
  damaged[24 + 9 + 12 + 5] ^= 0x40;
  std::ofstream(dir_ / "part.json.features.2.bin", std::ios::binary | std::ios::trunc) << damaged;
  const std::string error = (dir_ / "error.txt").string();
  EXPECT_EQ(RunGraphslamRedirected({"solve", store, "--streaming-poses", "0", "--initialization",
                                    "odometry", "--max-iterations", "5", "--checkpoint",
                                    (dir_ / "part.json").string(), "--resume", "-q"},
                                   error),
            2);  // Corruption
  const std::string message = bytes(error);
  EXPECT_NE(message.find((dir_ / "part.json.features.2.bin").string() +
                         ": offset 24: record checksum mismatch"),
            std::string::npos)
      << message;
}

// The same with --solver pcg: the PCG's warm start, forcing term and forest
// are in the checkpoint's state file (version 4, storage/solver_state_file.h),
// and the resumed solve takes the very steps of the uninterrupted one (same
// -o bytes, chi2, CG iterations); a damaged state file stops the resume with
// the file and the offset.
TEST_F(OutOfCoreTest, StreamingPcgResumeFromAStateFileEqualsTheUninterruptedSolve) {
  const std::string input = Simulate(700, 12);
  const std::string store = (dir_ / "store").string();
  ASSERT_EQ(RunGraphslam({"ingest", input, "-o", store, "--chunk-observations", "250", "-q"}), 0);
  const auto args = [&](const std::string& name, const std::string& iterations) {
    return std::vector<std::string>{
        "solve", store, "--streaming-poses", "0", "--initialization", "odometry",
        "--solver", "pcg", "--max-iterations", iterations, "--checkpoint",
        (dir_ / (name + ".json")).string(), "-o", (dir_ / (name + ".g2o")).string(),
        "--features-csv", (dir_ / (name + ".csv")).string(), "--report",
        (dir_ / (name + "_report.json")).string(), "--threads", "2", "-q"};
  };
  const auto solve = [&](const std::string& name, const std::string& iterations, bool resume) {
    std::vector<std::string> a = args(name, iterations);
    if (resume) a.push_back("--resume");
    const int code = RunGraphslam(a);
    return code == 0 || code == 4;
  };
  const auto bytes = [](const fs::path& path) { return graphslam::testing::ReadWholeFile(path); };
  ASSERT_TRUE(solve("full", "5", false));
  ASSERT_TRUE(solve("part", "2", false));
  const nlohmann::json checkpoint = ReadJson(dir_ / "part.json");
  const std::string checkpoint_bytes = bytes(dir_ / "part.json");  // sealed: restored as is
  EXPECT_EQ(checkpoint["version"], 4);
  EXPECT_FALSE(checkpoint.contains("pcg")) << "PCG state written as JSON";
  EXPECT_FALSE(checkpoint.contains("poses")) << "poses written as JSON";
  ASSERT_TRUE(fs::exists(dir_ / "part.json.state.2.bin"));
  const std::string saved = bytes(dir_ / "part.json.state.2.bin");
  const std::string saved_features = bytes(dir_ / "part.json.features.2.bin");
  ASSERT_TRUE(solve("part", "5", true));
  const nlohmann::json full = ReadJson(dir_ / "full_report.json");
  const nlohmann::json resumed = ReadJson(dir_ / "part_report.json");
  EXPECT_EQ(resumed["solver"], "pcg");
  EXPECT_EQ(resumed["resumed_from_iteration"].get<int>(), 2);
  EXPECT_EQ(full["final_chi2"].get<double>(), resumed["final_chi2"].get<double>());
  EXPECT_EQ(full["iterations"].get<int>(), resumed["iterations"].get<int>());
  EXPECT_EQ(bytes(dir_ / "full.g2o"), bytes(dir_ / "part.g2o"));
  EXPECT_EQ(bytes(dir_ / "full.csv"), bytes(dir_ / "part.csv"));
  EXPECT_FALSE(fs::exists(dir_ / "part.json.state.2.bin")) << "old generation kept";
  EXPECT_FALSE(fs::exists(dir_ / "part.json.ids.bin")) << "parked ids left behind";

  // Back to generation 2, with a flipped byte in the state file's summary.
  for (const char* name : {"part.json.features.5.bin", "part.json.state.5.bin"})
    fs::remove(dir_ / name);
  std::ofstream(dir_ / "part.json", std::ios::binary | std::ios::trunc) << checkpoint_bytes;
  std::string damaged = saved;
  damaged[24 + 9 + 20] ^= 0x40;
  std::ofstream(dir_ / "part.json.state.2.bin", std::ios::binary | std::ios::trunc) << damaged;
  std::ofstream(dir_ / "part.json.features.2.bin", std::ios::binary | std::ios::trunc)
      << saved_features;
  const std::string error = (dir_ / "error.txt").string();
  std::vector<std::string> resume = args("part", "5");
  resume.push_back("--resume");
  EXPECT_EQ(RunGraphslamRedirected(resume, error), 2);  // Corruption
  const std::string message = bytes(error);
  EXPECT_NE(message.find((dir_ / "part.json.state.2.bin").string() +
                         ": offset 24: record checksum mismatch"),
            std::string::npos)
      << message;
}

// kill -9 during a streaming PCG solve (as soon as its first checkpoint, the
// JSON naming the feature and state files, is on disk), then --resume: the
// same final chi2, iteration count and -o bytes as the uninterrupted solve.
TEST_F(OutOfCoreTest, KillNineMidStreamingPcgSolveThenResumeEqualsUninterruptedRun) {
  const std::string input = Simulate(2000, 4);
  const std::string store = (dir_ / "store").string();
  ASSERT_EQ(RunGraphslam({"ingest", input, "-o", store, "--chunk-observations", "500", "-q"}), 0);
  const std::vector<std::string> options = {"--streaming-poses", "0", "--initialization",
                                            "odometry", "--solver", "pcg", "--threads", "2"};
  const auto with_options = [&](std::vector<std::string> args) {
    args.insert(args.end(), options.begin(), options.end());
    return args;
  };
  ASSERT_EQ(RunGraphslam(with_options({"solve", store, "-o", (dir_ / "full.g2o").string(),
                                       "--report", (dir_ / "full.json").string(), "--checkpoint",
                                       (dir_ / "full_checkpoint.json").string(), "-q"})),
            0);
  const fs::path checkpoint = dir_ / "checkpoint.json";
  ASSERT_TRUE(graphslam::testing::SpawnAndKillAtStopPoint(
      with_options({"solve", store, "-o", (dir_ / "resumed.g2o").string(), "--checkpoint",
                    checkpoint.string(), "-q"}),
      "solver_checkpoint 2"))
      << "the solve ended before its second checkpoint";
  const nlohmann::json at_kill = ReadJson(checkpoint);
  const int iteration = at_kill["iterations"].get<int>();
  ASSERT_EQ(iteration, 2);
  EXPECT_EQ(at_kill["version"].get<int>(), 4);
  EXPECT_TRUE(fs::exists(dir_ / ("checkpoint.json.state." + std::to_string(iteration) + ".bin")));
  graphslam::testing::ExpectResumeEqualsUninterrupted(store, dir_, checkpoint, iteration, options);
}

}  // namespace
