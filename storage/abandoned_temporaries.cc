#include "storage/abandoned_temporaries.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <filesystem>

namespace graphslam::storage {
namespace {

namespace fs = std::filesystem;

// The pid of "<base>[.<anything>].tmp-<pid>", or -1 if `name` is not one.
long long TemporaryPid(const std::string& name, const std::string& base) {
  if (name.size() <= base.size() || name.compare(0, base.size(), base) != 0 ||
      name[base.size()] != '.')
    return -1;
  const size_t at = name.rfind(".tmp-");
  if (at == std::string::npos || at < base.size()) return -1;
  const std::string digits = name.substr(at + 5);
  if (digits.empty() || digits.size() > 18 ||
      digits.find_first_not_of("0123456789") != std::string::npos)
    return -1;
  return std::strtoll(digits.c_str(), nullptr, 10);
}

bool ProcessExists(long long pid) {
  if (pid <= 0) return true;  // not a pid we can rule out
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH;
}

// True if nobody holds a lock on `path` (and it could be opened to ask).
bool Unlocked(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) return false;
  const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);  // also releases the lock just taken
  return free;
}

}  // namespace

StatusOr<int64_t> RemoveAbandonedTemporaries(const std::string& path) {
  if (path.empty() || path == "-") return int64_t{0};
  const fs::path target(path);
  const std::string base = target.filename().string();
  if (base.empty()) return int64_t{0};
  fs::path dir = target.parent_path();
  if (dir.empty()) dir = ".";
  std::error_code error;
  if (!fs::is_directory(dir, error)) return int64_t{0};
  int64_t removed = 0;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    const std::string name = entry.path().filename().string();
    const long long pid = TemporaryPid(name, base);
    if (pid < 0 || entry.is_symlink(error) || !entry.is_regular_file(error)) continue;
    if (ProcessExists(pid) || !Unlocked(entry.path().string())) continue;
    if (fs::remove(entry.path(), error)) ++removed;
    if (error)
      return Status::IOError(entry.path().string() + ": remove an abandoned temporary: " +
                             error.message());
  }
  if (error) return Status::IOError(dir.string() + ": list: " + error.message());
  return removed;
}

}  // namespace graphslam::storage
