// DirectoryLock: one writer per folder (a chunk store, a solve's --workdir, a
// job's output folder), readers shared -- flock(2) on DIR/.graphslam.lock.
//
//   exclusive  taken by every command that writes into DIR; the holder
//              writes its pid into the lock file (for the message below)
//   shared     taken by readers of a chunk store: any number at once, none
//              while a writer holds the exclusive lock
//
// Acquire never waits: if the lock is held in a conflicting mode it fails at
// once with IOError "DIR: locked by another graphslam process (pid N) ...", N
// read from the lock file ("pid unknown" if the holder has not written it
// yet, or holds it shared). The lock ends when the DirectoryLock is destroyed
// or the process dies (the kernel drops flock locks with the last descriptor),
// so a killed writer never leaves a stale lock; the lock file itself stays
// (removing it would race with a process opening it).
//
// flock locks belong to the open file description: two DirectoryLocks on one
// folder conflict even inside one process (tests rely on this to hold a lock
// while a child process tries to write). A reader on a read-only file system
// or folder (the lock file cannot be created) proceeds without a lock: no
// writer can change that folder either.
//
// THREAD SAFETY: a DirectoryLock is used by one thread. ALLOCATION: none.
#pragma once

#include <string>

#include "core/status.h"

namespace graphslam::storage {

inline constexpr const char* kDirectoryLockName = ".graphslam.lock";

class DirectoryLock {
 public:
  enum class Mode { kShared, kExclusive };

  // Locks the existing folder `dir`. IOError naming the folder and the
  // holder's pid if it is locked in a conflicting mode, or if the lock file
  // cannot be opened (exclusive mode), NotFound if `dir` does not exist.
  static StatusOr<DirectoryLock> Acquire(const std::string& dir, Mode mode);

  DirectoryLock() = default;
  DirectoryLock(DirectoryLock&& other) noexcept;
  DirectoryLock& operator=(DirectoryLock&& other) noexcept;
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;
  ~DirectoryLock();

  bool held() const { return fd_ >= 0; }
  // Unlocks now (the destructor does it otherwise).
  void Release();

 private:
  int fd_ = -1;
  bool exclusive_ = false;
};

}  // namespace graphslam::storage
