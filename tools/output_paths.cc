#include "tools/output_paths.h"

#include <unistd.h>

#include <filesystem>

#include "core/logging.h"
#include "storage/abandoned_temporaries.h"
#include "storage/env.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

Status CheckWritableFolder(const OutputPath& output, const fs::path& folder) {
  const storage::FileKind kind = storage::Env::Default()->KindOf(folder.string());
  const std::string where = output.option + " " + output.path + ": ";
  if (kind == storage::FileKind::kMissing)
    return Status::IOError(where + "the folder " + folder.string() +
                           " does not exist; expected an existing folder to write the output into");
  if (kind != storage::FileKind::kDirectory)
    return Status::IOError(where + folder.string() +
                           " is not a folder; expected a folder to write the output into");
  if (access(folder.c_str(), W_OK | X_OK) != 0)
    return Status::IOError(where + "the folder " + folder.string() +
                           " is not writable; expected a folder this user may create files in");
  return Status::Ok();
}

Status CheckOne(const OutputPath& output) {
  if (output.path.empty() || output.path == "-") return Status::Ok();
  storage::Env* env = storage::Env::Default();
  const fs::path path(output.path);
  const storage::FileKind kind = env->KindOf(output.path);
  if (output.folder) {
    if (kind != storage::FileKind::kMissing) return CheckWritableFolder(output, path);
    // Created with its parents: the nearest existing ancestor must take them.
    std::error_code error;
    fs::path ancestor = fs::absolute(path, error).parent_path();
    while (!ancestor.empty() && env->KindOf(ancestor.string()) == storage::FileKind::kMissing &&
           ancestor != ancestor.root_path())
      ancestor = ancestor.parent_path();
    return CheckWritableFolder(output, ancestor);
  }
  if (kind == storage::FileKind::kDirectory)
    return Status::IOError(output.option + " " + output.path +
                           ": is a folder; expected a file path for the output");
  // A device or FIFO is written in place (storage/atomic_file.h): its folder
  // need not be writable (/dev), the file itself must be.
  if (kind == storage::FileKind::kOther) {
    if (::access(output.path.c_str(), W_OK) != 0)
      return Status::IOError(output.option + " " + output.path + ": not writable");
    return Status::Ok();
  }
  fs::path parent = path.parent_path();
  if (parent.empty()) parent = ".";
  GS_RETURN_IF_ERROR(CheckWritableFolder(output, parent));
  // What a killed earlier writer of this output left behind goes now.
  StatusOr<int64_t> removed = storage::RemoveAbandonedTemporaries(output.path);
  if (!removed.ok()) return removed.status().WithContext(output.option + " " + output.path);
  if (*removed > 0)
    GS_LOG(INFO, "%s: removed %lld temporary file(s) a killed run left", output.path.c_str(),
           static_cast<long long>(*removed));
  return Status::Ok();
}

}  // namespace

Status CheckOutputPaths(const std::vector<OutputPath>& outputs) {
  for (const OutputPath& output : outputs) GS_RETURN_IF_ERROR(CheckOne(output));
  return Status::Ok();
}

}  // namespace graphslam::tools
