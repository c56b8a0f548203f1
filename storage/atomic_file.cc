#include "storage/atomic_file.h"

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

}  // namespace

std::string TemporaryFileName(const std::string& path) {
  return path + ".tmp-" + std::to_string(static_cast<long long>(::getpid()));
}

Status WriteFileAtomically(Env* env, const std::string& path,
                           const std::function<Status(WritableFile*)>& writer) {
  GS_CHECK(env != nullptr);
  const std::string context = "writing " + path;
  if (path.empty()) return Status::InvalidArgument("output path is empty; expected a file name");
  const std::string temporary = TemporaryFileName(path);

  StatusOr<std::unique_ptr<WritableFile>> opened = env->NewWritableFile(temporary);
  if (!opened.ok()) {
    RemoveTemporary(env, temporary);
    return opened.status().WithContext(context);
  }
  std::unique_ptr<WritableFile> file = std::move(opened).value();

  Status status = writer(file.get());
  if (status.ok()) status = file->Sync();
  if (status.ok()) {
    status = file->Close();
  } else {
    (void)file->Close();  // the first error is the one reported
  }
  file.reset();
  if (status.ok()) status = env->Rename(temporary, path);
  if (!status.ok()) {
    RemoveTemporary(env, temporary);
    return status.WithContext(context);
  }
  status = env->SyncDirectory(DirectoryOf(path));
  if (!status.ok()) return status.WithContext(context + " (file renamed, directory not synced)");
  return Status::Ok();
}

Status WriteStringAtomically(Env* env, const std::string& path, std::string_view contents) {
  return WriteFileAtomically(env, path,
                             [contents](WritableFile* file) { return file->Append(contents); });
}

}  // namespace graphslam::storage
