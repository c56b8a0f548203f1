#include "storage/directory_lock.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>

namespace graphslam::storage {
namespace {

// The pid the holder wrote, or "pid unknown".
std::string HolderOf(int fd) {
  char buffer[32] = {};
  const ssize_t n = ::pread(fd, buffer, sizeof(buffer) - 1, 0);
  std::string text(buffer, n > 0 ? static_cast<size_t>(n) : 0);
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
  if (text.empty() || text.find_first_not_of("0123456789") != std::string::npos)
    return "pid unknown";
  return "pid " + text;
}

}  // namespace

StatusOr<DirectoryLock> DirectoryLock::Acquire(const std::string& dir, Mode mode) {
  std::error_code error;
  if (!std::filesystem::is_directory(dir, error))
    return Status::NotFound(dir + ": no such folder to lock");
  const std::string path = (std::filesystem::path(dir) / kDirectoryLockName).string();
  int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0 && mode == Mode::kShared) {
    const int open_errno = errno;
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0 && (open_errno == EROFS || open_errno == EACCES))
      return DirectoryLock();  // read-only: nobody can write it either
  }
  if (fd < 0) return Status::IOError(path + ": cannot open lock file: " + std::strerror(errno));
  const int operation = (mode == Mode::kExclusive ? LOCK_EX : LOCK_SH) | LOCK_NB;
  if (::flock(fd, operation) != 0) {
    const int lock_errno = errno;
    const std::string holder = HolderOf(fd);
    ::close(fd);
    if (lock_errno == EWOULDBLOCK)
      return Status::IOError(dir + ": locked by another graphslam process (" + holder + ") " +
                             (mode == Mode::kExclusive ? "using it" : "writing it") +
                             "; wait for it to finish or stop it (lock file " + path + ")");
    return Status::IOError(path + ": flock: " + std::strerror(lock_errno));
  }
  if (mode == Mode::kExclusive) {
    const std::string pid = std::to_string(::getpid()) + "\n";
    if (::ftruncate(fd, 0) != 0 ||
        ::pwrite(fd, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
      const int write_errno = errno;
      ::close(fd);
      return Status::IOError(path + ": cannot write the holder's pid: " +
                             std::strerror(write_errno));
    }
  }
  DirectoryLock lock;
  lock.fd_ = fd;
  lock.exclusive_ = mode == Mode::kExclusive;
  return lock;
}

DirectoryLock::DirectoryLock(DirectoryLock&& other) noexcept
    : fd_(other.fd_), exclusive_(other.exclusive_) {
  other.fd_ = -1;
}

DirectoryLock& DirectoryLock::operator=(DirectoryLock&& other) noexcept {
  if (this != &other) {
    Release();
    fd_ = other.fd_;
    exclusive_ = other.exclusive_;
    other.fd_ = -1;
  }
  return *this;
}

DirectoryLock::~DirectoryLock() { Release(); }

void DirectoryLock::Release() {
  if (fd_ < 0) return;
  // No stale pid for the next conflict message (best effort).
  if (exclusive_ && ::ftruncate(fd_, 0) != 0) errno = 0;
  ::close(fd_);  // drops the flock
  fd_ = -1;
}

}  // namespace graphslam::storage
