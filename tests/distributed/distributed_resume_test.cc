// kill -9 of one rank of `mpirun -np 2 graphslam solve STORE/ --checkpoint`,
// then `mpirun ... --resume`, against the uninterrupted run
// (docs/distributed.md, "Checkpoints and --resume"): the same final chi2 and
// iteration count bit for bit, the same trajectory byte for byte, and the
// report says where it resumed. Once rank 1 is killed (a rank holding only
// its own features), once rank 0 (the one that writes the checkpoint and
// holds the store's arrays). The kill is at a stop point
// (storage/stop_point.h): the rank stops itself once every rank knows the
// checkpoint of iteration 3 is durable (rank 0 wrote it), so the kill lands
// at exactly that point whatever the load.
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

class DistributedResumeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("graphslam_distributed_resume_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The solve's arguments writing DIR/name.json, DIR/name.tum and the
  // checkpoint DIR/name.checkpoint.json.
  std::vector<std::string> SolveArgs(const fs::path& store, const std::string& name) const {
    return {"solve", store.string(), "--report", (dir_ / (name + ".json")).string(),
            "--tum", (dir_ / (name + ".tum")).string(), "--checkpoint",
            (dir_ / (name + ".checkpoint.json")).string(), "--threads", "1", "-q",
            // From dead reckoning: enough iterations to kill one mid-way.
            "--initialization", "odometry"};
  }

  // Kills `rank` of `mpirun -np 2` once the checkpoint of iteration 3 is
  // durable, resumes, and compares with the uninterrupted run.
  void KillAndResume(const std::string& rank) {
    const fs::path sim = dir_ / "sim";
    ASSERT_EQ(graphslam::testing::RunGraphslam({"simulate", "-o", sim.string(), "--poses", "800",
                                                "--runs", "2", "--gps-every", "50", "--seed",
                                                "3", "-q"}),
              0);
    const fs::path store = dir_ / "campus";
    ASSERT_EQ(graphslam::testing::RunGraphslam({"ingest", (sim / "log.graphslam").string(), "-o",
                                                store.string(), "--chunk-observations", "300",
                                                "-q"}),
              0);
    ASSERT_EQ(graphslam::testing::RunMpi(2, SolveArgs(store, "full")), 0);
    const nlohmann::json full = nlohmann::json::parse(ReadWholeFile(dir_ / "full.json"));
    ASSERT_TRUE(full["converged"].get<bool>());
    ASSERT_GT(full["iterations"].get<int>(), 3);

    ASSERT_TRUE(graphslam::testing::KillRankAtStopPoint(2, SolveArgs(store, "run"),
                                                         "rank " + rank + " solver_checkpoint 3",
                                                         dir_ / "stopped.pid"));
    EXPECT_FALSE(fs::exists(dir_ / "run.json"));  // killed before its outputs
    const nlohmann::json checkpoint =
        nlohmann::json::parse(ReadWholeFile(dir_ / "run.checkpoint.json"));
    EXPECT_EQ(checkpoint["iterations"].get<int>(), 3);

    std::vector<std::string> resume = SolveArgs(store, "run");
    resume.push_back("--resume");
    ASSERT_EQ(graphslam::testing::RunMpi(2, resume), 0);
    const nlohmann::json resumed = nlohmann::json::parse(ReadWholeFile(dir_ / "run.json"));
    EXPECT_EQ(resumed["resumed_from_iteration"].get<int>(), 3);
    EXPECT_EQ(resumed["final_chi2"].get<double>(), full["final_chi2"].get<double>());
    EXPECT_EQ(resumed["iterations"].get<int>(), full["iterations"].get<int>());
    for (const char* key : {"eliminated_features", "excluded_features", "kept_features"})
      EXPECT_EQ(resumed[key], full[key]) << key;
    EXPECT_EQ(ReadWholeFile(dir_ / "run.tum"), ReadWholeFile(dir_ / "full.tum"));
  }

  fs::path dir_;
};

// Rank 1 holds only its own features.
TEST_F(DistributedResumeTest, KilledRankOneResumesToTheUninterruptedAnswer) {
  KillAndResume("1");
}

// Rank 0 writes the checkpoint and holds the store's arrays.
TEST_F(DistributedResumeTest, KilledRankZeroResumesToTheUninterruptedAnswer) {
  KillAndResume("0");
}

}  // namespace
