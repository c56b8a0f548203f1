// mpirun for the distributed tests: `mpirun --allow-run-as-root
// --oversubscribe -np N graphslam args...` (root in containers; more ranks
// than the machine's cores), GRAPHSLAM_MPIEXEC from tests/distributed/CMakeLists.txt.
#pragma once

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/testing/subprocess.h"

namespace graphslam::testing {

// Starts mpirun with `ranks` processes of `graphslam args...`, with
// `environment` (NAME, VALUE) added to its environment (mpirun passes it on
// to the ranks it starts here); returns mpirun's pid.
inline pid_t SpawnMpi(int ranks, const std::vector<std::string>& args,
                      const std::vector<std::pair<std::string, std::string>>& environment = {}) {
  std::vector<std::string> all = {GRAPHSLAM_MPIEXEC, "--allow-run-as-root", "--oversubscribe",
                                  "-np", std::to_string(ranks), GraphslamBinary()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    for (const auto& [name, value] : environment) setenv(name.c_str(), value.c_str(), 1);
    execv(argv[0], argv.data());
    _exit(127);
  }
  return pid;
}

// mpirun -np `ranks` graphslam args...; its exit code (-1 if killed).
inline int RunMpi(int ranks, const std::vector<std::string>& args) {
  return WaitForExit(SpawnMpi(ranks, args));
}

// Runs mpirun -np `ranks` graphslam args... with GRAPHSLAM_STOP_AT=`point`
// (storage/stop_point.h, e.g. "rank 1 solver_checkpoint 3"): the rank that
// reaches the point writes its pid to `pid_file` and stops; it is killed
// with SIGKILL there, and mpirun (which then ends the other ranks) is
// reaped. Returns true if a rank was killed at the point, false if mpirun
// ended first. No deadline: the wait ends with the stop or with mpirun.
inline bool KillRankAtStopPoint(int ranks, const std::vector<std::string>& args,
                                const std::string& point, const std::filesystem::path& pid_file) {
  std::filesystem::remove(pid_file);
  const pid_t mpirun = SpawnMpi(ranks, args, {{"GRAPHSLAM_STOP_AT", point},
                                              {"GRAPHSLAM_STOP_PID_FILE", pid_file.string()}});
  int status = 0;
  while (!std::filesystem::exists(pid_file)) {
    if (waitpid(mpirun, &status, WNOHANG) == mpirun) return false;  // ended first
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  long rank_pid = 0;
  std::ifstream(pid_file) >> rank_pid;
  const bool killed = rank_pid > 0 && kill(static_cast<pid_t>(rank_pid), SIGKILL) == 0;
  waitpid(mpirun, &status, 0);  // mpirun ends the others; always reaped
  return killed;
}

}  // namespace graphslam::testing
