// kill -9 tests: start the graphslam binary, kill it with SIGKILL at a stop
// point (storage/stop_point.h), so a resume can be compared with an
// uninterrupted run.
#pragma once

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/testing/directory_bytes.h"
#include "tests/testing/subprocess.h"

namespace graphslam::testing {

// Runs `graphslam args...` with GRAPHSLAM_STOP_AT=`point` (storage/
// stop_point.h): the child stops itself right after that point, is killed
// with SIGKILL there and reaped. Deterministic: no polling, no deadline.
// Returns true if the child was killed at the point, false if it ended
// without reaching it.
inline bool SpawnAndKillAtStopPoint(const std::vector<std::string>& args,
                                    const std::string& point) {
  const pid_t pid = SpawnGraphslamRedirected(args, "", {{"GRAPHSLAM_STOP_AT", point}});
  int status = 0;
  if (waitpid(pid, &status, WUNTRACED) != pid) return false;
  if (!WIFSTOPPED(status)) return false;  // ended (exited or crashed) first
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);  // always reaped: no child outlives the test
  return WIFSIGNALED(status) && WTERMSIG(status) == SIGKILL;
}

// Runs `graphslam solve input -o DIR/resumed.g2o --checkpoint checkpoint`
// (plus `solve_options`) and kills it with SIGKILL right after its
// checkpoint number `iteration`; expects that it was killed there, that the
// checkpoint records that iteration and that no output was left; the
// checkpoint's JSON goes to *at_kill. Call it under ASSERT_NO_FATAL_FAILURE.
inline void KillSolveAtCheckpoint(const std::string& input, const std::filesystem::path& dir,
                                  const std::filesystem::path& checkpoint, int iteration,
                                  const std::vector<std::string>& solve_options,
                                  nlohmann::json* at_kill) {
  std::vector<std::string> args = {"solve", input, "-o", (dir / "resumed.g2o").string(),
                                   "--checkpoint", checkpoint.string(), "-q"};
  args.insert(args.end(), solve_options.begin(), solve_options.end());
  const std::string point = "solver_checkpoint " + std::to_string(iteration);
  ASSERT_TRUE(SpawnAndKillAtStopPoint(args, point)) << "the solve ended before its " << point;
  ASSERT_TRUE(std::filesystem::exists(checkpoint)) << "no checkpoint was written";
  *at_kill = nlohmann::json::parse(ReadWholeFile(checkpoint));
  ASSERT_EQ((*at_kill)["iterations"].get<int>(), iteration);
  EXPECT_FALSE(std::filesystem::exists(dir / "resumed.g2o"))
      << "a killed solve must not leave its output";
}

// Resumes `graphslam solve input` from `checkpoint` into DIR/resumed.g2o and
// DIR/resumed.json, and expects what the uninterrupted run wrote to
// DIR/full.g2o and DIR/full.json: the same final chi2 and iteration count
// (bit for bit), the same graph byte for byte, and a report saying it resumed
// after iteration `killed_at_iteration`. `solve_options` (e.g. --solver pcg)
// are passed as they were to the interrupted and the uninterrupted runs.
inline void ExpectResumeEqualsUninterrupted(const std::string& input,
                                            const std::filesystem::path& dir,
                                            const std::filesystem::path& checkpoint,
                                            int killed_at_iteration,
                                            const std::vector<std::string>& solve_options = {}) {
  std::vector<std::string> args = {"solve", input, "-o", (dir / "resumed.g2o").string(),
                                   "--report", (dir / "resumed.json").string(), "--checkpoint",
                                   checkpoint.string(), "--resume", "-q"};
  args.insert(args.end(), solve_options.begin(), solve_options.end());
  ASSERT_EQ(RunGraphslam(args), 0);
  const nlohmann::json full = nlohmann::json::parse(ReadWholeFile(dir / "full.json"));
  const nlohmann::json resumed = nlohmann::json::parse(ReadWholeFile(dir / "resumed.json"));
  EXPECT_EQ(full["final_chi2"].get<double>(), resumed["final_chi2"].get<double>());
  EXPECT_EQ(full["iterations"].get<int>(), resumed["iterations"].get<int>());
  EXPECT_EQ(resumed["resumed_from_iteration"].get<int>(), killed_at_iteration);
  EXPECT_EQ(ReadWholeFile(dir / "full.g2o"), ReadWholeFile(dir / "resumed.g2o"));
}

}  // namespace graphslam::testing
