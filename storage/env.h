// Env: the small filesystem interface every writer in graphslam goes through
// (after LevelDB's include/leveldb/env.h and util/env_posix.cc).
//
// Writers never call open()/rename() directly; they ask an Env. Production code
// uses Env::Default() (POSIX); tests substitute FaultInjectionEnv, which wraps a
// real Env and makes the N-th Append/Sync/Close/Rename/... fail with IOError, so
// the "kill between write and rename" and "disk full during write" paths of
// WriteFileAtomically (atomic_file.h) can be asserted.
//
//   WritableFile: Append* -> Sync (fsync: data durable) -> Close; Flush
//                 (write(2) without fsync) for logs read while written
//   Env:          NewWritableFile, Rename (atomic on POSIX within one
//                 filesystem), RemoveFile, FileExists, SyncDirectory (fsync of
//                 a directory: makes a rename durable), KindOf / ResolvePath /
//                 OpenStream (outputs that are devices, FIFOs or symlinks are
//                 written in place or through the link, never replaced)
//   Scratch data: NewReadableFile (sequential reads, seeks), NewAppendableFile,
//                 SyncFile (fsync by path), ReadFileToString
//   Folders:      CreateDir (mkdir -p), RemoveDir (an empty one), RemoveTree
//                 (rm -r), ListDir, ListTree (the files below a folder),
//                 FileSize, TruncateFile
//
// Every operation that touches the disk returns a Status; IOError messages name
// the path and the errno text, e.g. "out.g2o: fsync: No space left on device".
//
// THREAD SAFETY: Env::Default() and FaultInjectionEnv may be used from several
// threads at once. One WritableFile must not be used by two threads at once.
// ALLOCATION: a PosixWritableFile holds a 64 KiB write buffer.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace graphslam::storage {

// A file opened for sequential writing. Destroying an unclosed file closes it
// and ignores errors; call Close() to see them.
class WritableFile {
 public:
  WritableFile() = default;
  WritableFile(const WritableFile&) = delete;
  WritableFile& operator=(const WritableFile&) = delete;
  virtual ~WritableFile() = default;

  [[nodiscard]] virtual Status Append(std::string_view data) = 0;
  // Hands buffered data to the kernel (write(2), no fsync): after OK the data
  // survive a kill of the process, not a power loss. For files with no
  // buffer of their own the default does nothing.
  [[nodiscard]] virtual Status Flush() { return Status::Ok(); }
  // Flushes buffers and fsyncs: after OK the data survive a power loss.
  [[nodiscard]] virtual Status Sync() = 0;
  // Flushes and closes. Further calls except the destructor are errors.
  [[nodiscard]] virtual Status Close() = 0;
};

// A file opened for reading: sequential reads from a position that Seek
// moves. Read fills `scratch` with up to `n` bytes and returns how many it
// read; fewer than `n` only at the end of the file.
class ReadableFile {
 public:
  ReadableFile() = default;
  ReadableFile(const ReadableFile&) = delete;
  ReadableFile& operator=(const ReadableFile&) = delete;
  virtual ~ReadableFile() = default;

  virtual StatusOr<size_t> Read(size_t n, char* scratch) = 0;
  [[nodiscard]] virtual Status Seek(uint64_t offset) = 0;
  virtual StatusOr<uint64_t> Size() = 0;
};

// What a path names, after following symbolic links.
enum class FileKind {
  kMissing,
  kRegular,
  kDirectory,
  kOther,  // a character or block device, a FIFO, a socket
};

class Env {
 public:
  Env() = default;
  Env(const Env&) = delete;
  Env& operator=(const Env&) = delete;
  virtual ~Env() = default;

  // Creates (or truncates) `path` for writing.
  virtual StatusOr<std::unique_ptr<WritableFile>> NewWritableFile(const std::string& path) = 0;
  // Atomically replaces `to` by `from` (POSIX rename(2)).
  [[nodiscard]] virtual Status Rename(const std::string& from, const std::string& to) = 0;
  [[nodiscard]] virtual Status RemoveFile(const std::string& path) = 0;
  virtual bool FileExists(const std::string& path) = 0;
  // fsyncs the directory `path` so that renames and creations inside it are
  // durable ("" means the current directory).
  [[nodiscard]] virtual Status SyncDirectory(const std::string& path) = 0;
  // What `path` names, following symbolic links (stat(2)).
  virtual FileKind KindOf(const std::string& path) = 0;
  // `path` with every symbolic link resolved (realpath(3)); it must exist.
  virtual StatusOr<std::string> ResolvePath(const std::string& path) = 0;
  // Opens a file that exists and is not a regular file (a device, a FIFO, a
  // terminal) for writing in place, without creating or truncating it; "-"
  // is standard output. Its Sync() flushes without fsync, which such files
  // do not support.
  virtual StatusOr<std::unique_ptr<WritableFile>> OpenStream(const std::string& path) = 0;

  // Scratch and record files. The defaults go to Env::Default(), so an Env
  // that only changes how outputs are written reads through POSIX.
  // Opens `path` for reading; NotFound when it does not exist.
  virtual StatusOr<std::unique_ptr<ReadableFile>> NewReadableFile(const std::string& path);
  // Opens `path` for writing at its end, creating it if it does not exist.
  virtual StatusOr<std::unique_ptr<WritableFile>> NewAppendableFile(const std::string& path);
  // fsyncs the existing file `path` (written earlier through another handle).
  [[nodiscard]] virtual Status SyncFile(const std::string& path);

  // Folders and sizes of scratch and store files; the defaults go to
  // Env::Default() as above. IOError messages read "PATH: mkdir: ...",
  // "PATH: remove: ...", "PATH: list: ...", "PATH: truncate: ...".
  // Creates `path` and its missing parents (mkdir -p); OK if it exists.
  [[nodiscard]] virtual Status CreateDir(const std::string& path);
  // Removes the directory `path` if it is empty (rmdir(2)).
  [[nodiscard]] virtual Status RemoveDir(const std::string& path);
  // Removes `path` and everything below it (rm -r); OK if it does not exist.
  [[nodiscard]] virtual Status RemoveTree(const std::string& path);
  // The names (not paths) of the entries of the directory `path`, sorted.
  virtual StatusOr<std::vector<std::string>> ListDir(const std::string& path);
  // The regular files anywhere below the directory `path` (not following
  // links to folders), as paths relative to it with '/' between the parts,
  // sorted: "a.bin", "sub/b.bin".
  virtual StatusOr<std::vector<std::string>> ListTree(const std::string& path);
  // The size in bytes of the file `path`.
  virtual StatusOr<uint64_t> FileSize(const std::string& path);
  // Cuts the file `path` to its first `size` bytes (truncate(2)).
  [[nodiscard]] virtual Status TruncateFile(const std::string& path, uint64_t size);

  // The process-wide POSIX Env. It is a function-local static, the one
  // singleton the project permits: it holds no state (every call goes straight
  // to the kernel), so sharing it cannot couple callers, and it is never
  // destroyed before its users because it is never destroyed at all
  // (LevelDB's Env::Default() does the same). Never null.
  static Env* Default();
};

// Wraps another Env and fails chosen operations with IOError, for tests
// (LevelDB's test::ErrorEnv / FaultInjectionTestEnv). Operations are counted
// from construction (or the last Reset()), 1-based, across all files opened
// through this Env: FailAt(Operation::kSync, 1) makes the first Sync fail.
// A failed operation does not reach the wrapped Env (a failed Append writes
// nothing, a failed Rename renames nothing).
class FaultInjectionEnv : public Env {
 public:
  enum class Operation {
    kNewWritableFile = 0,
    kAppend,
    kSync,
    kClose,
    kRename,
    kRemoveFile,
    kSyncDirectory,
  };
  static constexpr int kNumOperations = 7;

  // `base` must outlive this Env and every file opened through it.
  explicit FaultInjectionEnv(Env* base);

  // The nth (1-based) call of `operation` from now on the counter fails;
  // nth <= 0 disables. Each operation has one pending failure at most.
  void FailAt(Operation operation, int nth);
  // Every call of `operation` from now on fails (a full disk, a dead device).
  void FailAlways(Operation operation);
  // Clears pending failures and counters.
  void Reset();
  // How many times `operation` was called (including failed calls).
  int Count(Operation operation) const;

  StatusOr<std::unique_ptr<WritableFile>> NewWritableFile(const std::string& path) override;
  [[nodiscard]] Status Rename(const std::string& from, const std::string& to) override;
  [[nodiscard]] Status RemoveFile(const std::string& path) override;
  bool FileExists(const std::string& path) override;
  [[nodiscard]] Status SyncDirectory(const std::string& path) override;
  FileKind KindOf(const std::string& path) override;
  StatusOr<std::string> ResolvePath(const std::string& path) override;
  StatusOr<std::unique_ptr<WritableFile>> OpenStream(const std::string& path) override;
  StatusOr<std::unique_ptr<ReadableFile>> NewReadableFile(const std::string& path) override;
  StatusOr<std::unique_ptr<WritableFile>> NewAppendableFile(const std::string& path) override;
  [[nodiscard]] Status SyncFile(const std::string& path) override;
  // Forwarded without faults.
  [[nodiscard]] Status CreateDir(const std::string& path) override;
  [[nodiscard]] Status RemoveDir(const std::string& path) override;
  [[nodiscard]] Status RemoveTree(const std::string& path) override;
  StatusOr<std::vector<std::string>> ListDir(const std::string& path) override;
  StatusOr<std::vector<std::string>> ListTree(const std::string& path) override;
  StatusOr<uint64_t> FileSize(const std::string& path) override;
  [[nodiscard]] Status TruncateFile(const std::string& path, uint64_t size) override;

  // Counts a call of `operation`; returns IOError if this call is to fail.
  // Public for the wrapped files; not part of the test-facing API.
  [[nodiscard]] Status MaybeFail(Operation operation, const std::string& path);

 private:
  Env* const base_;
  mutable std::mutex mutex_;
  int counts_[kNumOperations] = {};
  int fail_at_[kNumOperations] = {};   // 0: no pending failure
  bool fail_always_[kNumOperations] = {};
};

// The whole of `path` (NotFound when it does not exist).
StatusOr<std::string> ReadFileToString(Env* env, const std::string& path);
// The same, but NotFound(`missing`) when `path` does not exist: a message
// that says what the caller expected there ("PATH: no such job file").
StatusOr<std::string> ReadFileToString(Env* env, const std::string& path,
                                       const std::string& missing);

}  // namespace graphslam::storage
