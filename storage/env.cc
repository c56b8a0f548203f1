#include "storage/env.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

namespace graphslam::storage {
namespace {

Status PosixError(const std::string& path, const char* operation, int error_number) {
  return Status::IOError(path + ": " + operation + ": " + std::strerror(error_number));
}

Status FilesystemError(const std::string& path, const char* operation,
                       const std::error_code& error) {
  return Status::IOError(path + ": " + operation + ": " + error.message());
}

// Buffered writer over a POSIX file descriptor (LevelDB PosixWritableFile).
class PosixWritableFile final : public WritableFile {
 public:
  static constexpr size_t kBufferSize = 64 * 1024;

  // A stream (a device, a FIFO, standard output) is flushed, not fsynced.
  PosixWritableFile(std::string path, int fd, bool stream = false)
      : path_(std::move(path)), fd_(fd), stream_(stream) {
    buffer_.reserve(kBufferSize);
  }
  ~PosixWritableFile() override {
    if (fd_ >= 0) ::close(fd_);  // errors are only reported by Close()
  }

  Status Append(std::string_view data) override {
    if (fd_ < 0) return Status::IOError(path_ + ": append after close");
    if (buffer_.size() + data.size() <= kBufferSize) {
      buffer_.append(data);
      return Status::Ok();
    }
    GS_RETURN_IF_ERROR(Flush());
    if (data.size() <= kBufferSize) {
      buffer_.append(data);
      return Status::Ok();
    }
    return WriteUnbuffered(data);
  }

  Status Sync() override {
    if (fd_ < 0) return Status::IOError(path_ + ": sync after close");
    GS_RETURN_IF_ERROR(Flush());
    if (stream_) return Status::Ok();
    if (::fsync(fd_) != 0) return PosixError(path_, "fsync", errno);
    return Status::Ok();
  }

  Status Close() override {
    if (fd_ < 0) return Status::IOError(path_ + ": close called twice");
    Status status = Flush();
    if (::close(fd_) != 0 && status.ok()) status = PosixError(path_, "close", errno);
    fd_ = -1;
    return status;
  }

  Status Flush() override {
    if (fd_ < 0) return Status::IOError(path_ + ": flush after close");
    Status status = WriteUnbuffered(buffer_);
    buffer_.clear();
    return status;
  }

 private:

  Status WriteUnbuffered(std::string_view data) {
    while (!data.empty()) {
      const ssize_t written = ::write(fd_, data.data(), data.size());
      if (written < 0) {
        if (errno == EINTR) continue;
        return PosixError(path_, "write", errno);
      }
      data.remove_prefix(static_cast<size_t>(written));
    }
    return Status::Ok();
  }

  const std::string path_;
  int fd_;
  const bool stream_;
  std::string buffer_;
};

// Unbuffered reader over a POSIX file descriptor; callers read whole frames
// or records, so each Read is one or a few read(2) calls.
class PosixReadableFile final : public ReadableFile {
 public:
  PosixReadableFile(std::string path, int fd) : path_(std::move(path)), fd_(fd) {}
  ~PosixReadableFile() override { ::close(fd_); }

  StatusOr<size_t> Read(size_t n, char* scratch) override {
    size_t done = 0;
    while (done < n) {
      const ssize_t got = ::read(fd_, scratch + done, n - done);
      if (got < 0) {
        if (errno == EINTR) continue;
        return PosixError(path_, "read", errno);
      }
      if (got == 0) break;
      done += static_cast<size_t>(got);
    }
    return done;
  }

  Status Seek(uint64_t offset) override {
    if (::lseek(fd_, static_cast<off_t>(offset), SEEK_SET) < 0)
      return PosixError(path_, "seek", errno);
    return Status::Ok();
  }

  StatusOr<uint64_t> Size() override {
    struct stat info;
    if (::fstat(fd_, &info) != 0) return PosixError(path_, "size", errno);
    return static_cast<uint64_t>(info.st_size);
  }

 private:
  const std::string path_;
  const int fd_;
};

class PosixEnv final : public Env {
 public:
  StatusOr<std::unique_ptr<WritableFile>> NewWritableFile(const std::string& path) override {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return PosixError(path, "open for writing", errno);
    return std::unique_ptr<WritableFile>(std::make_unique<PosixWritableFile>(path, fd));
  }

  Status Rename(const std::string& from, const std::string& to) override {
    if (::rename(from.c_str(), to.c_str()) != 0) {
      return PosixError(from, ("rename to " + to).c_str(), errno);
    }
    return Status::Ok();
  }

  Status RemoveFile(const std::string& path) override {
    if (::unlink(path.c_str()) != 0) return PosixError(path, "unlink", errno);
    return Status::Ok();
  }

  bool FileExists(const std::string& path) override { return ::access(path.c_str(), F_OK) == 0; }

  FileKind KindOf(const std::string& path) override {
    struct stat info;
    if (::stat(path.c_str(), &info) != 0) return FileKind::kMissing;
    if (S_ISREG(info.st_mode)) return FileKind::kRegular;
    if (S_ISDIR(info.st_mode)) return FileKind::kDirectory;
    return FileKind::kOther;
  }

  StatusOr<std::string> ResolvePath(const std::string& path) override {
    char* resolved = ::realpath(path.c_str(), nullptr);
    if (resolved == nullptr) return PosixError(path, "resolve path", errno);
    std::string result(resolved);
    std::free(resolved);
    return result;
  }

  StatusOr<std::unique_ptr<WritableFile>> OpenStream(const std::string& path) override {
    if (path == "-") {
      const int fd = ::fcntl(STDOUT_FILENO, F_DUPFD_CLOEXEC, 0);
      if (fd < 0) return PosixError("standard output", "dup", errno);
      return std::unique_ptr<WritableFile>(
          std::make_unique<PosixWritableFile>("standard output", fd, /*stream=*/true));
    }
    const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) return PosixError(path, "open for writing", errno);
    return std::unique_ptr<WritableFile>(
        std::make_unique<PosixWritableFile>(path, fd, /*stream=*/true));
  }

  StatusOr<std::unique_ptr<ReadableFile>> NewReadableFile(const std::string& path) override {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) {
      if (errno == ENOENT)
        return Status::NotFound(path + ": open for reading: " + std::strerror(errno));
      return PosixError(path, "open for reading", errno);
    }
    return std::unique_ptr<ReadableFile>(std::make_unique<PosixReadableFile>(path, fd));
  }

  StatusOr<std::unique_ptr<WritableFile>> NewAppendableFile(const std::string& path) override {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd < 0) return PosixError(path, "open for append", errno);
    return std::unique_ptr<WritableFile>(std::make_unique<PosixWritableFile>(path, fd));
  }

  Status SyncFile(const std::string& path) override {
    const int fd = ::open(path.c_str(), O_WRONLY | O_CLOEXEC);
    if (fd < 0) return PosixError(path, "open for fsync", errno);
    Status status;
    if (::fsync(fd) != 0) status = PosixError(path, "fsync", errno);
    ::close(fd);
    return status;
  }

  Status SyncDirectory(const std::string& path) override {
    const std::string directory = path.empty() ? "." : path;
    const int fd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return PosixError(directory, "open directory", errno);
    Status status;
    if (::fsync(fd) != 0) status = PosixError(directory, "fsync directory", errno);
    ::close(fd);
    return status;
  }

  Status CreateDir(const std::string& path) override {
    std::error_code error;
    std::filesystem::create_directories(path, error);
    if (error) return FilesystemError(path, "mkdir", error);
    return Status::Ok();
  }

  Status RemoveDir(const std::string& path) override {
    if (::rmdir(path.c_str()) != 0) return PosixError(path, "rmdir", errno);
    return Status::Ok();
  }

  Status RemoveTree(const std::string& path) override {
    std::error_code error;
    std::filesystem::remove_all(path, error);
    if (error) return FilesystemError(path, "remove", error);
    return Status::Ok();
  }

  StatusOr<std::vector<std::string>> ListDir(const std::string& path) override {
    std::error_code error;
    std::vector<std::string> names;
    std::filesystem::directory_iterator it(path, error);
    for (; !error && it != std::filesystem::directory_iterator(); it.increment(error))
      names.push_back(it->path().filename().string());
    if (error) return FilesystemError(path, "list", error);
    std::sort(names.begin(), names.end());
    return names;
  }

  StatusOr<std::vector<std::string>> ListTree(const std::string& path) override {
    namespace fs = std::filesystem;
    std::error_code error;
    std::vector<std::string> files;
    fs::recursive_directory_iterator it(path, error);
    for (; !error && it != fs::recursive_directory_iterator(); it.increment(error)) {
      std::error_code kind_error;
      if (!it->is_regular_file(kind_error)) continue;
      files.push_back(it->path().lexically_relative(path).generic_string());
    }
    if (error) return FilesystemError(path, "list", error);
    std::sort(files.begin(), files.end());
    return files;
  }

  StatusOr<uint64_t> FileSize(const std::string& path) override {
    struct stat info;
    if (::stat(path.c_str(), &info) != 0) return PosixError(path, "stat", errno);
    if (!S_ISREG(info.st_mode)) return Status::IOError(path + ": size: not a regular file");
    return static_cast<uint64_t>(info.st_size);
  }

  Status TruncateFile(const std::string& path, uint64_t size) override {
    if (::truncate(path.c_str(), static_cast<off_t>(size)) != 0)
      return PosixError(path, "truncate", errno);
    return Status::Ok();
  }
};

// Forwards to the wrapped file after asking the FaultInjectionEnv whether this
// call is to fail.
class FaultInjectionWritableFile final : public WritableFile {
 public:
  FaultInjectionWritableFile(std::string path, std::unique_ptr<WritableFile> base,
                             FaultInjectionEnv* env)
      : path_(std::move(path)), base_(std::move(base)), env_(env) {}

  Status Append(std::string_view data) override {
    GS_RETURN_IF_ERROR(env_->MaybeFail(FaultInjectionEnv::Operation::kAppend, path_));
    return base_->Append(data);
  }
  Status Flush() override { return base_->Flush(); }
  Status Sync() override {
    GS_RETURN_IF_ERROR(env_->MaybeFail(FaultInjectionEnv::Operation::kSync, path_));
    return base_->Sync();
  }
  Status Close() override {
    GS_RETURN_IF_ERROR(env_->MaybeFail(FaultInjectionEnv::Operation::kClose, path_));
    return base_->Close();
  }

 private:
  const std::string path_;
  std::unique_ptr<WritableFile> base_;
  FaultInjectionEnv* const env_;
};

const char* OperationName(FaultInjectionEnv::Operation operation) {
  switch (operation) {
    case FaultInjectionEnv::Operation::kNewWritableFile: return "open";
    case FaultInjectionEnv::Operation::kAppend: return "append";
    case FaultInjectionEnv::Operation::kSync: return "sync";
    case FaultInjectionEnv::Operation::kClose: return "close";
    case FaultInjectionEnv::Operation::kRename: return "rename";
    case FaultInjectionEnv::Operation::kRemoveFile: return "remove";
    case FaultInjectionEnv::Operation::kSyncDirectory: return "sync directory";
  }
  return "unknown operation";
}

}  // namespace

Env* Env::Default() {
  // Intentionally leaked function-local static (see env.h): stateless, never
  // destroyed, so usable from other statics' destructors.
  static PosixEnv* const env = new PosixEnv();
  return env;
}

StatusOr<std::unique_ptr<ReadableFile>> Env::NewReadableFile(const std::string& path) {
  return Default()->NewReadableFile(path);
}

StatusOr<std::unique_ptr<WritableFile>> Env::NewAppendableFile(const std::string& path) {
  return Default()->NewAppendableFile(path);
}

Status Env::SyncFile(const std::string& path) { return Default()->SyncFile(path); }

Status Env::CreateDir(const std::string& path) { return Default()->CreateDir(path); }

Status Env::RemoveDir(const std::string& path) { return Default()->RemoveDir(path); }

Status Env::RemoveTree(const std::string& path) { return Default()->RemoveTree(path); }

StatusOr<std::vector<std::string>> Env::ListDir(const std::string& path) {
  return Default()->ListDir(path);
}

StatusOr<std::vector<std::string>> Env::ListTree(const std::string& path) {
  return Default()->ListTree(path);
}

StatusOr<uint64_t> Env::FileSize(const std::string& path) { return Default()->FileSize(path); }

Status Env::TruncateFile(const std::string& path, uint64_t size) {
  return Default()->TruncateFile(path, size);
}

StatusOr<std::string> ReadFileToString(Env* env, const std::string& path) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<ReadableFile> file, env->NewReadableFile(path));
  GS_ASSIGN_OR_RETURN(const uint64_t size, file->Size());
  std::string bytes(static_cast<size_t>(size), '\0');
  GS_ASSIGN_OR_RETURN(const size_t got, file->Read(bytes.size(), bytes.data()));
  bytes.resize(got);  // a file that shrank meanwhile
  return bytes;
}

StatusOr<std::string> ReadFileToString(Env* env, const std::string& path,
                                       const std::string& missing) {
  StatusOr<std::string> bytes = ReadFileToString(env, path);
  if (!bytes.ok() && bytes.status().IsNotFound()) return Status::NotFound(missing);
  return bytes;
}

FaultInjectionEnv::FaultInjectionEnv(Env* base) : base_(base) { GS_CHECK(base != nullptr); }

void FaultInjectionEnv::FailAt(Operation operation, int nth) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int index = static_cast<int>(operation);
  fail_at_[index] = nth > 0 ? counts_[index] + nth : 0;
}

void FaultInjectionEnv::FailAlways(Operation operation) {
  std::lock_guard<std::mutex> lock(mutex_);
  fail_always_[static_cast<int>(operation)] = true;
}

void FaultInjectionEnv::Reset() {
  std::lock_guard<std::mutex> lock(mutex_);
  for (int i = 0; i < kNumOperations; ++i) {
    counts_[i] = 0;
    fail_at_[i] = 0;
    fail_always_[i] = false;
  }
}

int FaultInjectionEnv::Count(Operation operation) const {
  std::lock_guard<std::mutex> lock(mutex_);
  return counts_[static_cast<int>(operation)];
}

Status FaultInjectionEnv::MaybeFail(Operation operation, const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  const int index = static_cast<int>(operation);
  const int call = ++counts_[index];
  if (fail_always_[index] || call == fail_at_[index]) {
    return Status::IOError(path + ": " + OperationName(operation) + ": injected fault (call " +
                           std::to_string(call) + ")");
  }
  return Status::Ok();
}

StatusOr<std::unique_ptr<WritableFile>> FaultInjectionEnv::NewWritableFile(
    const std::string& path) {
  GS_RETURN_IF_ERROR(MaybeFail(Operation::kNewWritableFile, path));
  GS_ASSIGN_OR_RETURN(std::unique_ptr<WritableFile> base, base_->NewWritableFile(path));
  return std::unique_ptr<WritableFile>(
      std::make_unique<FaultInjectionWritableFile>(path, std::move(base), this));
}

Status FaultInjectionEnv::Rename(const std::string& from, const std::string& to) {
  GS_RETURN_IF_ERROR(MaybeFail(Operation::kRename, from));
  return base_->Rename(from, to);
}

Status FaultInjectionEnv::RemoveFile(const std::string& path) {
  GS_RETURN_IF_ERROR(MaybeFail(Operation::kRemoveFile, path));
  return base_->RemoveFile(path);
}

bool FaultInjectionEnv::FileExists(const std::string& path) { return base_->FileExists(path); }

FileKind FaultInjectionEnv::KindOf(const std::string& path) { return base_->KindOf(path); }

StatusOr<std::string> FaultInjectionEnv::ResolvePath(const std::string& path) {
  return base_->ResolvePath(path);
}

StatusOr<std::unique_ptr<WritableFile>> FaultInjectionEnv::OpenStream(const std::string& path) {
  GS_RETURN_IF_ERROR(MaybeFail(Operation::kNewWritableFile, path));
  GS_ASSIGN_OR_RETURN(std::unique_ptr<WritableFile> base, base_->OpenStream(path));
  return std::unique_ptr<WritableFile>(
      std::make_unique<FaultInjectionWritableFile>(path, std::move(base), this));
}

StatusOr<std::unique_ptr<ReadableFile>> FaultInjectionEnv::NewReadableFile(
    const std::string& path) {
  return base_->NewReadableFile(path);
}

StatusOr<std::unique_ptr<WritableFile>> FaultInjectionEnv::NewAppendableFile(
    const std::string& path) {
  GS_RETURN_IF_ERROR(MaybeFail(Operation::kNewWritableFile, path));
  GS_ASSIGN_OR_RETURN(std::unique_ptr<WritableFile> base, base_->NewAppendableFile(path));
  return std::unique_ptr<WritableFile>(
      std::make_unique<FaultInjectionWritableFile>(path, std::move(base), this));
}

Status FaultInjectionEnv::SyncFile(const std::string& path) {
  GS_RETURN_IF_ERROR(MaybeFail(Operation::kSync, path));
  return base_->SyncFile(path);
}

Status FaultInjectionEnv::SyncDirectory(const std::string& path) {
  GS_RETURN_IF_ERROR(MaybeFail(Operation::kSyncDirectory, path));
  return base_->SyncDirectory(path);
}

Status FaultInjectionEnv::CreateDir(const std::string& path) { return base_->CreateDir(path); }

Status FaultInjectionEnv::RemoveDir(const std::string& path) { return base_->RemoveDir(path); }

Status FaultInjectionEnv::RemoveTree(const std::string& path) { return base_->RemoveTree(path); }

StatusOr<std::vector<std::string>> FaultInjectionEnv::ListDir(const std::string& path) {
  return base_->ListDir(path);
}

StatusOr<std::vector<std::string>> FaultInjectionEnv::ListTree(const std::string& path) {
  return base_->ListTree(path);
}

StatusOr<uint64_t> FaultInjectionEnv::FileSize(const std::string& path) {
  return base_->FileSize(path);
}

Status FaultInjectionEnv::TruncateFile(const std::string& path, uint64_t size) {
  return base_->TruncateFile(path, size);
}

}  // namespace graphslam::storage
