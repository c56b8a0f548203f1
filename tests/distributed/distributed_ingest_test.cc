// `mpirun -np 3 graphslam ingest LOG -o STORE/` (docs/distributed.md, "Ingest
// on ranks"): the manifest lists one shard of chunks per rank, covering the
// chunks in order; the chunk and problem files are byte for byte those of a
// one-process ingest (same sizes and CRC32Cs); and the store solves, in one
// process and under `mpirun -np 2`, to the final chi2 and iteration count of
// the one-process ingest + solve (one process: bit for bit; two ranks: within
// 1e-9 relative, the sums are grouped by rank).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "tests/distributed/mpi_launch.h"
#include "tests/testing/directory_bytes.h"
#include "tests/testing/subprocess.h"

namespace {

namespace fs = std::filesystem;
using graphslam::testing::ReadWholeFile;
using graphslam::testing::RunGraphslam;
using graphslam::testing::RunMpi;

class DistributedIngestTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("graphslam_distributed_ingest_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Solves `store` (one process with `ranks` 0, else mpirun -np ranks) with
  // exact steps (CHOLMOD; PETSc's CG to 1e-10) from one start; its report.
  nlohmann::json Solve(const fs::path& store, int ranks, const std::string& name) {
    std::vector<std::string> args = {"solve",     store.string(), "--report",
                                     (dir_ / (name + ".json")).string(),
                                     "--checkpoint", (dir_ / (name + ".checkpoint.json")).string(),
                                     "--threads", "1", "-q", "--initial-trust-region", "1e4",
                                     // The start of the optimization, not the stage solves
                                     // of an initialization (which follow --solver).
                                     "--initialization", "odometry"};
    if (ranks == 0) args.insert(args.end(), {"--solver", "cholmod"});
    EXPECT_EQ(ranks == 0 ? RunGraphslam(args) : RunMpi(ranks, args), 0) << name;
    return nlohmann::json::parse(ReadWholeFile(dir_ / (name + ".json")));
  }

  fs::path dir_;
};

TEST_F(DistributedIngestTest, StoreWrittenByThreeRanksSolvesOnTwoAndOne) {
  const fs::path sim = dir_ / "sim";
  ASSERT_EQ(RunGraphslam({"simulate", "-o", sim.string(), "--poses", "800", "--runs", "2",
                          "--gps-every", "50", "--seed", "3", "-q"}),
            0);
  const std::string log = (sim / "log.graphslam").string();
  const fs::path one = dir_ / "one";
  const fs::path three = dir_ / "three";
  ASSERT_EQ(RunGraphslam({"ingest", log, "-o", one.string(), "--chunk-observations", "300",
                          "-q"}),
            0);
  // Buckets of at most 600 observations: each rank spills only its shard's
  // (partition/ingest/streaming_ingest.h); the chunks do not depend on the buffer.
  ASSERT_EQ(RunMpi(3, {"ingest", log, "-o", three.string(), "--chunk-observations", "300",
                       "--buffer-observations", "600", "-q"}),
            0);

  const nlohmann::json m1 = nlohmann::json::parse(ReadWholeFile(one / "MANIFEST.json"));
  const nlohmann::json m3 = nlohmann::json::parse(ReadWholeFile(three / "MANIFEST.json"));
  EXPECT_FALSE(m1.contains("shards"));
  ASSERT_TRUE(m3.contains("shards"));
  ASSERT_EQ(m3["shards"].size(), 3u);
  const int64_t chunks = m3["num_chunks"].get<int64_t>();
  ASSERT_GE(chunks, 3);  // every rank wrote a shard
  int64_t next = 0;
  for (int r = 0; r < 3; ++r) {
    const nlohmann::json& shard = m3["shards"][r];
    EXPECT_EQ(shard["rank"].get<int>(), r);
    EXPECT_EQ(shard["first_chunk"].get<int64_t>(), next);
    EXPECT_EQ(shard["chunks"].get<int64_t>(), chunks * (r + 1) / 3 - chunks * r / 3);
    next += shard["chunks"].get<int64_t>();
  }
  EXPECT_EQ(next, chunks);
  // The same files as one process writes.
  EXPECT_EQ(m3["chunks"], m1["chunks"]);
  EXPECT_EQ(m3["files"], m1["files"]);
  // No scratch of any rank left behind.
  for (const fs::directory_entry& entry : fs::directory_iterator(three))
    EXPECT_EQ(entry.path().filename().string().rfind("work", 0), std::string::npos)
        << entry.path();

  const nlohmann::json reference = Solve(one, 0, "reference");
  ASSERT_TRUE(reference["converged"].get<bool>());
  const double chi2 = reference["final_chi2"].get<double>();
  const nlohmann::json by_one = Solve(three, 0, "one_process");
  EXPECT_EQ(by_one["final_chi2"].get<double>(), chi2);
  EXPECT_EQ(by_one["iterations"], reference["iterations"]);
  const nlohmann::json by_two = Solve(three, 2, "two_ranks");
  EXPECT_EQ(by_two["distributed"]["ranks"].get<int>(), 2);
  EXPECT_NEAR(by_two["final_chi2"].get<double>(), chi2, 1e-9 * chi2);
  EXPECT_EQ(by_two["iterations"], reference["iterations"]);
}

}  // namespace
