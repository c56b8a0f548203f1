// kill -9 during `graphslam ingest` never leaves a store that opens (the
// manifest is removed first and written last), and rerunning the ingest gives
// a complete store whose solve equals the in-memory solve; kill -9 during
// `solve FILE --workdir DIR`, then --resume, reuses the store and ends exactly
// as an uninterrupted run (docs/out_of_core.md).
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
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

class IngestKillTest : public graphslam::testing::OutOfCoreFixture {};

TEST_F(IngestKillTest, KillNineDuringIngestNeverLeavesAStoreThatOpens) {
  const std::string input = Simulate(1500, 9);
  const fs::path store = dir_ / "store";
  // A complete store first, so the kill must also un-commit an old manifest.
  ASSERT_EQ(RunGraphslam({"ingest", input, "-o", store.string(), "-q"}), 0);
  ASSERT_TRUE(fs::exists(store / "MANIFEST.json"));
  // A small buffer makes the ingest spill many times; kill it after the second spill.
  ASSERT_TRUE(graphslam::testing::SpawnAndKillAtStopPoint(
      {"ingest", input, "-o", store.string(), "--chunk-observations", "256",
       "--buffer-observations", "256", "-q"},
      "ingest_spill 2"))
      << "the ingest ended before its second spill";
  EXPECT_FALSE(fs::exists(store / "MANIFEST.json")) << "a killed ingest left a manifest";
  EXPECT_EQ(RunGraphslam({"solve", store.string(), "-q"}), 2) << "incomplete store accepted";
  // Rerun: complete, and solving it equals the in-memory solve.
  ASSERT_EQ(RunGraphslam({"ingest", input, "-o", store.string(), "--chunk-observations", "256",
                          "--buffer-observations", "256", "-q"}),
            0);
  ASSERT_EQ(RunGraphslam({"solve", store.string(), "--chunk-observations", "256", "--report",
                          (dir_ / "store.json").string(), "--max-iterations", "3", "-q"}) % 4,
            0);
  ASSERT_EQ(RunGraphslam({"solve", input, "--chunk-observations", "256", "--report",
                          (dir_ / "memory.json").string(), "--max-iterations", "3", "-q"}) % 4,
            0);
  ExpectSameChi2(ReadJson(dir_ / "memory.json"), ReadJson(dir_ / "store.json"));
}

// kill -9 after the first-pass record, during the spill, and during the chunk
// writes; `ingest --resume` then gives the uninterrupted ingest's store, every
// file byte for byte (docs/formats/ingest_progress.md).
TEST_F(IngestKillTest, KillNineAtSeveralPointsThenResumeGivesTheSameStoreBytes) {
  const std::string input = Simulate(3000, 5);
  const std::vector<std::string> options = {"--chunk-observations", "128", "--buffer-observations",
                                            "512", "--checkpoint-seconds", "0", "-q"};
  auto ingest = [&](const fs::path& store, bool resume) {
    std::vector<std::string> args = {"ingest", input, "-o", store.string()};
    args.insert(args.end(), options.begin(), options.end());
    if (resume) args.push_back("--resume");
    return args;
  };
  ASSERT_EQ(RunGraphslam(ingest(dir_ / "full", false)), 0);
  const auto expected = graphslam::testing::FilesUnder(dir_ / "full");
  ASSERT_GT(expected.size(), 50u);
  const fs::path store = dir_ / "store";
  // After the first pass was recorded, during the spill, and during the chunk
  // writes (storage/stop_point.h).
  for (const std::string point : {"ingest_pass1", "ingest_spill 3", "ingest_chunks 30"}) {
    SCOPED_TRACE("killed at " + point);
    fs::remove_all(store);
    ASSERT_TRUE(graphslam::testing::SpawnAndKillAtStopPoint(ingest(store, false), point))
        << "the ingest ended before " << point;
    EXPECT_FALSE(fs::exists(store / "MANIFEST.json")) << "a killed ingest committed";
    EXPECT_TRUE(fs::exists(store / "work" / "ingest_progress.json"));
    ASSERT_EQ(RunGraphslam(ingest(store, true)), 0);
    graphslam::testing::ExpectSameFiles(graphslam::testing::FilesUnder(store), expected);
  }
}

// kill -9 while the FeatureIndex waits in work/pass1.bin and the
// initialization has not run: no progress record exists, so `--resume`
// starts afresh (the half-done pass 1 is discarded) and gives the
// uninterrupted ingest's store, byte for byte; an ingest that reads the
// index back from that file gives it too.
TEST_F(IngestKillTest, KillNineWithTheIndexOnDiskThenResumeStartsAfresh) {
  const std::string input = Simulate(2000, 6);
  auto ingest = [&](const fs::path& store, bool resume) {
    std::vector<std::string> args = {"ingest", input, "-o", store.string(),
                                     "--chunk-observations", "128", "-q"};
    if (resume) args.push_back("--resume");
    return args;
  };
  ASSERT_EQ(RunGraphslam(ingest(dir_ / "full", false)), 0);
  const auto expected = graphslam::testing::FilesUnder(dir_ / "full");
  const fs::path store = dir_ / "store";
  ASSERT_TRUE(
      graphslam::testing::SpawnAndKillAtStopPoint(ingest(store, false), "ingest_index_on_disk"))
      << "the ingest ended before writing its index";
  EXPECT_TRUE(fs::exists(store / "work" / "pass1.bin"));
  EXPECT_FALSE(fs::exists(store / "work" / "ingest_progress.json"));
  EXPECT_FALSE(fs::exists(store / "problem.graphslam"));
  ASSERT_EQ(RunGraphslam(ingest(store, true)), 0);
  graphslam::testing::ExpectSameFiles(graphslam::testing::FilesUnder(store), expected);
}

TEST_F(IngestKillTest, KillNineDuringWorkdirSolveThenResumeEqualsUninterruptedRun) {
  const std::string input = Simulate(1500, 4);
  ASSERT_EQ(RunGraphslam({"solve", input, "--workdir", (dir_ / "full").string(), "--report",
                          (dir_ / "full.json").string(), "-q"}),
            0);
  const fs::path store = dir_ / "store";
  const fs::path checkpoint = store / "checkpoint.json";
  ASSERT_TRUE(graphslam::testing::SpawnAndKillAtStopPoint(
      {"solve", input, "--workdir", store.string(), "-q"}, "solver_checkpoint 1"))
      << "the solve ended before its first checkpoint";
  ASSERT_TRUE(fs::exists(checkpoint)) << "no checkpoint was written";
  const int killed_after = ReadJson(checkpoint)["iterations"].get<int>();
  ASSERT_EQ(killed_after, 1);
  // --resume reuses the store (no second ingest) and continues from the checkpoint.
  const auto manifest_time = fs::last_write_time(store / "MANIFEST.json");
  ASSERT_EQ(RunGraphslam({"solve", input, "--workdir", store.string(), "--resume", "--report",
                          (dir_ / "resumed.json").string(), "-q"}),
            0);
  EXPECT_EQ(fs::last_write_time(store / "MANIFEST.json"), manifest_time) << "store re-ingested";
  const nlohmann::json full = ReadJson(dir_ / "full.json");
  const nlohmann::json resumed = ReadJson(dir_ / "resumed.json");
  EXPECT_EQ(full["final_chi2"].get<double>(), resumed["final_chi2"].get<double>());
  EXPECT_EQ(full["iterations"].get<int>(), resumed["iterations"].get<int>());
  EXPECT_EQ(resumed["resumed_from_iteration"].get<int>(), killed_after);
}

}  // namespace
