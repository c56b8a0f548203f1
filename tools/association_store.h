// Rewrites a chunk store (storage/chunk_store.h) after `graphslam solve STORE/
// --associate` has merged features, so that the store holds the associated
// problem: every observation in the chunk of the feature it was merged into
// (chunks stay feature-complete), the features' solved positions and ids in
// problem.graphslam, the solved poses as the next solve's initial guess.
//
// Atomicity: the new store is written completely into the sibling directory
// STORE.associating (WriteChunkStore: chunks, problem, MANIFEST.json last,
// each file fsynced), then the two directories are swapped in one step
// (Linux renameat2 RENAME_EXCHANGE) and the parent directory is fsynced; the
// old store, now at STORE.associating, is removed. A crash before the swap
// leaves the old store intact (and a stale STORE.associating that the next
// rewrite replaces); a crash after it leaves the new one. Where the file
// system cannot exchange directories, the store is rewritten in place under
// its own commit rule (MANIFEST.json removed first, written last: a crash
// leaves an incomplete store that every reader rejects, never a mixed one).
// Other files in STORE (a solver checkpoint) are dropped: they describe the
// problem before association.
//
// Locking: the caller holds STORE's exclusive lock; the staging store is
// locked while it is written, and that lock moves with the folder in the
// exchange (flock belongs to the open lock file, whose folder is now STORE).
// It is handed to the caller in `*store_lock`, replacing the lock of the old
// store, so STORE stays locked from before the rewrite to the caller's exit.
//
// THREAD SAFETY: one rewrite per store at a time. ALLOCATION: one chunk at a
// time beyond the problem.
#pragma once

#include <cstdint>
#include <string>

#include "core/problem.h"
#include "core/status.h"
#include "storage/directory_lock.h"
#include "storage/env.h"
#include "storage/file_checksum.h"

namespace graphslam::tools {

[[nodiscard]] Status RewriteAssociatedChunkStore(storage::Env* env, const std::string& store,
                                                 const core::Problem2d& problem,
                                                 int64_t chunk_observations,
                                                 const std::string& source,
                                                 const storage::FileChecksum& input,
                                                 storage::DirectoryLock* store_lock);

}  // namespace graphslam::tools
