#include "storage/store_directory.h"

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <system_error>
#include <vector>

#include "storage/atomic_file.h"
#include "storage/chunk_store.h"

namespace graphslam::storage {
namespace fs = std::filesystem;
namespace {

// True if dir/MANIFEST.json is a JSON object whose format is ours.
bool HoldsOurManifest(const fs::path& dir) {
  std::ifstream in(dir / kChunkStoreManifestName, std::ios::binary);
  if (!in) return false;
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const nlohmann::json manifest = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (manifest.is_discarded() || !manifest.is_object()) return false;
  auto format = manifest.find("format");
  return format != manifest.end() && format->is_string() &&
         format->get<std::string>() == kChunkStoreFormatName;
}

}  // namespace

bool IsTemporaryFileName(const std::string& name) {
  const size_t at = name.rfind(".tmp-");
  if (at == std::string::npos || at == 0) return false;
  const std::string digits = name.substr(at + 5);
  return !digits.empty() && digits.find_first_not_of("0123456789") == std::string::npos;
}

Status CheckStoreDirectory(const std::string& dir) {
  std::error_code error;
  const fs::path path(dir);
  if (!fs::exists(path, error)) return Status::Ok();
  if (!fs::is_directory(path, error))
    return Status::InvalidArgument(dir + ": exists and is not a folder; expected a chunk store "
                                   "folder, an empty folder or a new path");
  if (fs::exists(path / kStoreMarkerName, error) || HoldsOurManifest(path)) return Status::Ok();
  std::string foreign;
  for (const auto& entry : fs::directory_iterator(path, error)) {
    const std::string name = entry.path().filename().string();
    // The lock file, and the marker's temporary while another writer
    // claims the folder (it then holds the lock; ours to wait for).
    if (name == kDirectoryLockName || name == kStoreMarkerName ||
        (IsTemporaryFileName(name) && name.rfind(std::string(kStoreMarkerName) + ".tmp-", 0) == 0))
      continue;
    if (foreign.empty()) foreign = name;
  }
  if (error) return Status::IOError(dir + ": list: " + error.message());
  if (foreign.empty()) return Status::Ok();
  // Another writer may have renamed its marker into place after the check
  // above and then created its files, which the listing (in no particular
  // order) can show without the marker. A marker is never removed once
  // there, so a second look settles it: then the folder is ours, and that
  // writer's lock decides who writes.
  if (fs::exists(path / kStoreMarkerName, error) || HoldsOurManifest(path)) return Status::Ok();
  return Status::InvalidArgument(
      dir + ": folder is not empty and is not a graphslam chunk store (it holds '" + foreign +
      "'); nothing was written or deleted; choose a new or empty folder");
}

StatusOr<DirectoryLock> OpenStoreForWriting(Env* env, const std::string& dir) {
  GS_RETURN_IF_ERROR(CheckStoreDirectory(dir));
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) return Status::IOError(dir + ": mkdir: " + error.message());
  GS_ASSIGN_OR_RETURN(DirectoryLock lock,
                      DirectoryLock::Acquire(dir, DirectoryLock::Mode::kExclusive));
  // Another process may have written into it between the check and the lock.
  GS_RETURN_IF_ERROR(ClaimStoreDirectory(env, dir));
  return lock;
}

Status ClaimStoreDirectory(Env* env, const std::string& dir) {
  GS_RETURN_IF_ERROR(CheckStoreDirectory(dir));
  std::error_code error;
  fs::create_directories(dir, error);
  if (error) return Status::IOError(dir + ": mkdir: " + error.message());
  const std::string marker = (fs::path(dir) / kStoreMarkerName).string();
  if (env->FileExists(marker)) return Status::Ok();
  return WriteStringAtomically(env, marker, std::string(kChunkStoreFormatName) + "\n");
}

Status RemoveStaleTemporaries(Env* env, const std::string& dir, bool recursive) {
  std::error_code error;
  if (!fs::is_directory(dir, error)) return Status::Ok();
  std::vector<std::string> stale;
  std::vector<std::string> folders;
  for (const auto& entry : fs::directory_iterator(dir, error)) {
    if (entry.is_symlink(error)) continue;
    if (entry.is_regular_file(error) && IsTemporaryFileName(entry.path().filename().string()))
      stale.push_back(entry.path().string());
    else if (recursive && entry.is_directory(error))
      folders.push_back(entry.path().string());
  }
  if (error) return Status::IOError(dir + ": list: " + error.message());
  for (const std::string& file : stale) GS_RETURN_IF_ERROR(env->RemoveFile(file));
  for (const std::string& folder : folders)
    GS_RETURN_IF_ERROR(RemoveStaleTemporaries(env, folder, true));
  return Status::Ok();
}

}  // namespace graphslam::storage
