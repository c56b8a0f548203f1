#include "storage/atomic_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <memory>

#include "core/logging.h"

namespace graphslam::storage {
namespace {

std::string DirectoryOf(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

// Best-effort cleanup after a failure: the original error is what the caller
// needs; a failed cleanup is only logged.
void RemoveTemporary(Env* env, const std::string& temporary) {
  if (!env->FileExists(temporary)) return;
  const Status status = env->RemoveFile(temporary);
  if (!status.ok()) {
    GS_LOG(WARNING, "could not remove temporary file %s: %s", temporary.c_str(),
           status.ToString().c_str());
  }
}

// Runs `writer` on `file`, then Sync and Close; the first error wins.
Status WriteSyncClose(WritableFile* file, const std::function<Status(WritableFile*)>& writer) {
  Status status = writer(file);
  if (status.ok()) status = file->Sync();
  if (status.ok()) return file->Close();
  (void)file->Close();  // the first error is the one reported
  return status;
}

// A device, a FIFO or standard output: written in place, never replaced.
Status WriteStream(Env* env, const std::string& path,
                   const std::function<Status(WritableFile*)>& writer) {
  const std::string context =
      "writing " + (path == kStandardOutput ? std::string("standard output") : path);
  StatusOr<std::unique_ptr<WritableFile>> opened = env->OpenStream(path);
  if (!opened.ok()) return opened.status().WithContext(context);
  const Status status = WriteSyncClose(opened->get(), writer);
  return status.ok() ? status : status.WithContext(context);
}

// Steps 1-5 of the header for the regular file `target`; `path` is the name
// the caller gave, for messages.
Status ReplaceAtomically(Env* env, const std::string& path, const std::string& target,
                         const std::function<Status(WritableFile*)>& writer) {
  const std::string context = "writing " + path;
  const std::string temporary = TemporaryFileName(target);
  StatusOr<std::unique_ptr<WritableFile>> opened = env->NewWritableFile(temporary);
  if (!opened.ok()) {
    RemoveTemporary(env, temporary);
    return opened.status().WithContext(context);
  }
  std::unique_ptr<WritableFile> file = std::move(opened).value();
  // Held until the rename: a locked temporary is never taken for abandoned
  // (storage/abandoned_temporaries.h). Best effort: an Env whose files are
  // not on this file system has no descriptor to lock.
  const int lock_fd = ::open(temporary.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (lock_fd >= 0) (void)::flock(lock_fd, LOCK_EX | LOCK_NB);
  Status status = WriteSyncClose(file.get(), writer);
  file.reset();
  if (status.ok()) status = env->Rename(temporary, target);
  if (lock_fd >= 0) ::close(lock_fd);
  if (!status.ok()) {
    RemoveTemporary(env, temporary);
    return status.WithContext(context);
  }
  status = env->SyncDirectory(DirectoryOf(target));
  if (!status.ok()) return status.WithContext(context + " (file renamed, directory not synced)");
  return Status::Ok();
}

}  // namespace

std::string TemporaryFileName(const std::string& path) {
  return path + ".tmp-" + std::to_string(static_cast<long long>(::getpid()));
}

Status WriteFileAtomically(Env* env, const std::string& path,
                           const std::function<Status(WritableFile*)>& writer) {
  GS_CHECK(env != nullptr);
  if (path.empty()) return Status::InvalidArgument("output path is empty; expected a file name");
  if (path == kStandardOutput) return WriteStream(env, path, writer);
  switch (env->KindOf(path)) {
    case FileKind::kMissing:
      return ReplaceAtomically(env, path, path, writer);
    case FileKind::kOther:
      return WriteStream(env, path, writer);
    case FileKind::kDirectory:
      return Status::InvalidArgument("writing " + path +
                                     ": is a directory; expected a file name");
    case FileKind::kRegular: {
      // Through a symbolic link: replace the file it names, keep the link.
      StatusOr<std::string> target = env->ResolvePath(path);
      if (!target.ok()) return target.status().WithContext("writing " + path);
      return ReplaceAtomically(env, path, *target, writer);
    }
  }
  return Status::InvalidArgument("writing " + path + ": unknown file kind");
}

Status WriteStringAtomically(Env* env, const std::string& path, std::string_view contents) {
  return WriteFileAtomically(env, path,
                             [contents](WritableFile* file) { return file->Append(contents); });
}

}  // namespace graphslam::storage
