// Runs the graphslam binary of this build as a child process, for end-to-end
// tests that need a real process (exit codes, kill -9).
#pragma once

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "tests/testing/build_paths.h"

namespace graphslam::testing {

inline const std::string& GraphslamBinary() {
  static const std::string path = BinaryDir() + "/bin/graphslam";
  return path;
}

// Where a child's output goes and what it adds to its environment.
struct SpawnOptions {
  std::string stdout_path;  // "" : inherited; else this file (truncated)
  std::string stderr_path;  // "" : inherited; else this file (truncated)
  std::vector<std::pair<std::string, std::string>> environment;  // NAME, VALUE
};

// Starts `graphslam args...` as `options` say and returns its pid.
inline pid_t SpawnGraphslamWith(const std::vector<std::string>& args,
                                const SpawnOptions& options) {
  std::vector<char*> argv;
  argv.push_back(const_cast<char*>(GraphslamBinary().c_str()));
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    for (const auto& [name, value] : options.environment)
      setenv(name.c_str(), value.c_str(), 1);
    for (const auto& [path, target] : {std::pair{&options.stdout_path, 1},
                                       std::pair{&options.stderr_path, 2}}) {
      if (path->empty()) continue;
      const int fd = open(path->c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) dup2(fd, target);
    }
    execv(GraphslamBinary().c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

// Starts `graphslam args...` and returns its pid; unless `stderr_path` is
// empty the child's stderr goes to that file (truncated). `environment`
// holds NAME=VALUE pairs added to the child's environment.
inline pid_t SpawnGraphslamRedirected(
    const std::vector<std::string>& args, const std::string& stderr_path,
    const std::vector<std::pair<std::string, std::string>>& environment = {}) {
  return SpawnGraphslamWith(args, SpawnOptions{"", stderr_path, environment});
}

// Starts `graphslam args...` and returns its pid.
inline pid_t SpawnGraphslam(const std::vector<std::string>& args) {
  return SpawnGraphslamRedirected(args, "");
}

// Waits for a child to end; its exit code, -1 if it was killed.
inline int WaitForExit(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

// Runs `graphslam args...` to the end; its exit code, -1 if it was killed.
inline int RunGraphslam(const std::vector<std::string>& args) {
  return WaitForExit(SpawnGraphslam(args));
}

// What a finished `graphslam args...` printed and returned.
struct GraphslamRun {
  int exit_code = -1;  // -1 if it was killed
  std::string out;     // stdout
  std::string err;     // stderr
};

// Runs `graphslam args...` to the end with stdout and stderr captured through
// the files `capture_prefix`.out / .err (the caller's scratch folder).
inline GraphslamRun RunGraphslamCaptured(const std::vector<std::string>& args,
                                         const std::string& capture_prefix) {
  const std::string out_path = capture_prefix + ".out", err_path = capture_prefix + ".err";
  const pid_t pid = SpawnGraphslamWith(args, SpawnOptions{out_path, err_path, {}});
  GraphslamRun run;
  run.exit_code = WaitForExit(pid);
  auto slurp = [](const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
  };
  run.out = slurp(out_path);
  run.err = slurp(err_path);
  return run;
}

}  // namespace graphslam::testing
