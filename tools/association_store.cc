#include "tools/association_store.h"

#include <fcntl.h>
#include <stdio.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/logging.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/chunk_store.h"
#include "storage/directory_lock.h"
#include "storage/stop_point.h"
#include "storage/store_directory.h"

namespace graphslam::tools {
namespace {

// Exchanges two directories atomically. False (errno set) where unsupported.
bool ExchangeDirectories(const std::string& a, const std::string& b) {
#ifdef RENAME_EXCHANGE
  return ::renameat2(AT_FDCWD, a.c_str(), AT_FDCWD, b.c_str(), RENAME_EXCHANGE) == 0;
#else
  errno = ENOSYS;
  return false;
#endif
}

}  // namespace

Status RewriteAssociatedChunkStore(storage::Env* env, const std::string& store,
                                   const core::Problem2d& problem, int64_t chunk_observations,
                                   const std::string& source,
                                   const storage::FileChecksum& input,
                                   storage::DirectoryLock* store_lock) {
  std::string dir = store;
  while (dir.size() > 1 && dir.back() == '/') dir.pop_back();
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = chunk_observations;
  const partition::InMemoryChunkSource chunks(problem, chunking);
  storage::ChunkStoreWriteOptions options;
  options.source = source;
  options.input = input;

  const std::string staging = dir + ".associating";
  // A stale staging store of a killed rewrite is ours to remove; any other
  // folder of that name is not (storage/store_directory.h).
  GS_RETURN_IF_ERROR(storage::CheckStoreDirectory(staging));
  GS_RETURN_IF_ERROR(env->RemoveTree(staging).WithContext("remove stale staging store"));
  // Locked while written, and after the exchange, when it is STORE's lock.
  GS_ASSIGN_OR_RETURN(storage::DirectoryLock staging_lock,
                      storage::OpenStoreForWriting(env, staging));
  GS_RETURN_IF_ERROR(storage::WriteChunkStore(env, staging, problem, chunks, options));
  if (ExchangeDirectories(staging, dir)) {
    *store_lock = std::move(staging_lock);
    const std::filesystem::path parent = std::filesystem::absolute(dir).parent_path();
    GS_RETURN_IF_ERROR(env->SyncDirectory(parent.string()));
    if (Status removed = env->RemoveTree(staging); !removed.ok()) {
      GS_LOG(WARNING, "%s: could not remove the old store after the rewrite: %s",
             staging.c_str(), removed.message().c_str());
    }
    storage::StopPointForTests("associate_exchanged");
    return Status::Ok();
  }
  const int exchange_errno = errno;
  GS_LOG(WARNING, "%s: cannot exchange directories (%s); rewriting the store in place",
         dir.c_str(), std::strerror(exchange_errno));
  staging_lock.Release();
  (void)env->RemoveTree(staging);  // as before: the in-place rewrite goes on regardless
  // In place: the commit rule of WriteChunkStore; chunk files beyond the new
  // count are removed after the new manifest is durable.
  GS_RETURN_IF_ERROR(storage::WriteChunkStore(env, dir, problem, chunks, options));
  for (int64_t k = chunks.NumChunks();; ++k) {
    const std::string path = dir + "/" + storage::kChunkStoreChunkDirectory + "/" +
                             storage::ChunkStoreFileName(k);
    if (!env->FileExists(path)) break;
    GS_RETURN_IF_ERROR(env->RemoveFile(path));
  }
  return Status::Ok();
}

}  // namespace graphslam::tools
