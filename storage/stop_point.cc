#include "storage/stop_point.h"

#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <string>

#include <unistd.h>

namespace graphslam::storage {

namespace {

void StopHere() {
  std::fflush(nullptr);  // what was printed so far reaches the test
  if (const char* pid_file = std::getenv(kStopPidFileVariable); pid_file != nullptr) {
    // Complete or absent for the test that waits for it: written, then renamed.
    const std::string temporary = std::string(pid_file) + ".tmp";
    if (std::FILE* out = std::fopen(temporary.c_str(), "w"); out != nullptr) {
      std::fprintf(out, "%ld\n", static_cast<long>(getpid()));
      std::fclose(out);
      std::rename(temporary.c_str(), pid_file);
    }
  }
  std::raise(SIGSTOP);
}

}  // namespace

void StopPointForTests(std::string_view point) {
  const char* wanted = std::getenv(kStopPointVariable);
  if (wanted == nullptr || point != wanted) return;
  StopHere();
}

void StopPointAtCountForTests(std::string_view name, long long count) {
  const char* wanted = std::getenv(kStopPointVariable);
  if (wanted == nullptr) return;
  const std::string_view value(wanted);
  if (value.size() <= name.size() + 1 || value.substr(0, name.size()) != name ||
      value[name.size()] != ' ')
    return;
  char* end = nullptr;
  const long long threshold = std::strtoll(wanted + name.size() + 1, &end, 10);
  if (end == wanted + name.size() + 1 || *end != '\0') return;
  if (count >= threshold) StopHere();
}

}  // namespace graphslam::storage
