// kill -9 tests: start the graphslam binary, kill it with SIGKILL the moment
// a file (its first checkpoint) appears, so a resume can be compared with an
// uninterrupted run.
#pragma once

#include <signal.h>
#include <sys/wait.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tests/testing/subprocess.h"

namespace graphslam::testing {

// Runs `graphslam args...` and sends SIGKILL as soon as `file` exists (or
// after `timeout`). Returns true if the child died of the signal, false if it
// had already ended on its own.
inline bool SpawnAndKillWhenFileExists(const std::vector<std::string>& args,
                                       const std::filesystem::path& file,
                                       std::chrono::seconds timeout) {
  const pid_t pid = SpawnGraphslam(args);
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!std::filesystem::exists(file) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFSIGNALED(status);
}

// The whole content of a file ("" if it cannot be read).
inline std::string ReadWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace graphslam::testing
