// End-to-end tests of the out-of-core command line (docs/out_of_core.md):
// `graphslam solve FILE --workdir DIR` equals the in-memory solve; the
// streaming mode (observations stay on disk, the ingest's Table 1 guess)
// equals the in-memory solve from the same guess; --memory-limit bounds the
// chunks in flight. (kill -9 during an ingest: ingest_kill_test.cc.)
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/testing/subprocess.h"
#include "tests/tools/out_of_core_fixture.h"

namespace {

namespace fs = std::filesystem;

using graphslam::testing::GraphslamBinary;
using graphslam::testing::RunGraphslam;

using graphslam::testing::ReadJson;

class OutOfCoreTest : public graphslam::testing::OutOfCoreFixture {};

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
  // 1 MiB cannot hold the pose system of 600 poses (4 KiB each) and a chunk.
  EXPECT_NE(RunGraphslam({"solve", input, "--workdir", (dir_ / "store").string(),
                          "--memory-limit", "1M", "-q"}),
            0);
  EXPECT_EQ(RunGraphslam({"solve", input, "--memory-limit", "lots", "-q"}), 1);
  // 4 MiB: pose system ~2.4 MiB (600 poses), chunks of 1024 observations
  // 0.5 MiB each: 3 in flight.
  ASSERT_EQ(RunGraphslam({"solve", input, "--workdir", (dir_ / "store").string(),
                          "--memory-limit", "4M", "--chunk-observations", "1024", "--report",
                          (dir_ / "limited.json").string(), "-q"}),
            0);
  const nlohmann::json limited = ReadJson(dir_ / "limited.json");
  EXPECT_GE(limited["chunks_in_flight"].get<int>(), 1);
  EXPECT_LT(limited["chunks_in_flight"].get<int>(), 8);
  ASSERT_EQ(RunGraphslam({"solve", input, "--report", (dir_ / "free.json").string(),
                          "--chunk-observations", "1024", "-q"}),
            0);
  ExpectSameChi2(ReadJson(dir_ / "free.json"), limited);
}

}  // namespace
