// kill -9 during a 3-D solve, then --resume: the same result as without the
// kill. The graphslam binary solves sphere2500 (SE-Sync's g2o, 2500 SE(3)
// poses) as a child process, is killed with SIGKILL right after its first
// checkpoint is on disk, and is resumed; the final chi2, the iteration count
// and the optimized graph must equal those of an uninterrupted run bit for
// bit (3-D checkpoints: docs/formats/solver_checkpoint.md).
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/testing/datasets.h"
#include "tests/testing/kill_nine.h"

namespace {

namespace fs = std::filesystem;
using graphslam::testing::ExpectResumeEqualsUninterrupted;
using graphslam::testing::KillSolveAtCheckpoint;
using graphslam::testing::ReadWholeFile;
using graphslam::testing::RunGraphslam;

TEST(SolveResume3d, KillNineMidSolveThenResumeEqualsUninterruptedRun) {
  GS_REQUIRE_DATASET("sesync_posegraphs/sphere2500.g2o");
  const std::string input = graphslam::testing::DatasetPath("sesync_posegraphs/sphere2500.g2o");
  ASSERT_TRUE(fs::exists(graphslam::testing::GraphslamBinary()));
  const fs::path dir =
      fs::temp_directory_path() / ("graphslam_resume3d_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);

  // Uninterrupted reference (with a checkpoint too: writing one must not
  // change the solve).
  ASSERT_EQ(RunGraphslam({"solve", input, "-o", (dir / "full.g2o").string(), "--report",
                          (dir / "full.json").string(), "--checkpoint",
                          (dir / "full_checkpoint.json").string(), "-q"}),
            0);
  const nlohmann::json full_checkpoint =
      nlohmann::json::parse(ReadWholeFile(dir / "full_checkpoint.json"));
  EXPECT_EQ(full_checkpoint["dimension"].get<int>(), 3);
  EXPECT_TRUE(full_checkpoint["converged"].get<bool>());

  const fs::path checkpoint = dir / "checkpoint.json";
  nlohmann::json at_kill;
  ASSERT_NO_FATAL_FAILURE(KillSolveAtCheckpoint(input, dir, checkpoint, 1, {}, &at_kill));
  ASSERT_GT(full_checkpoint["iterations"].get<int>(), 1) << "nothing left to resume";

  ExpectResumeEqualsUninterrupted(input, dir, checkpoint, at_kill["iterations"].get<int>());

  fs::remove_all(dir);
}

}  // namespace
