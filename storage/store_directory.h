// Which folders graphslam may write a chunk store into, and what it may
// delete there (docs/guarantees.md): `graphslam ingest -o DIR` and `graphslam
// solve FILE --workdir DIR` never delete a file they cannot prove they wrote.
//
// A folder is OURS if it holds the marker file .graphslam-store (written by
// OpenStoreForWriting before anything else), or a MANIFEST.json whose
// "format" is graphslam-chunk-store (a store made before markers existed). A
// missing folder, an empty one, or one holding nothing but the lock file
// (storage/directory_lock.h) is claimed: the marker is written into it. Any
// other folder is FOREIGN: InvalidArgument naming it and one of its entries;
// nothing in it is touched.
//
// In a folder that is ours, under its exclusive lock, the store's own parts
// (chunks/, work/, scans/, the files of docs/formats/chunk_store.md) are ours
// to replace, and so are temporary files "NAME.tmp-PID" (atomic_file.h) that a
// killed writer left: no other writer can hold them (the lock), so
// RemoveStaleTemporaries removes them.
//
// THREAD SAFETY: the lock serializes writers of one folder. ALLOCATION: none.
#pragma once

#include <string>

#include "core/status.h"
#include "storage/directory_lock.h"
#include "storage/env.h"

namespace graphslam::storage {

inline constexpr const char* kStoreMarkerName = ".graphslam-store";

// OK if `dir` is missing, empty (but for the lock file) or ours; InvalidArgument
// naming `dir` and a foreign entry otherwise. Reads only.
[[nodiscard]] Status CheckStoreDirectory(const std::string& dir);

// Checks `dir` (above), creates it if missing and writes the marker: from
// here the folder is ours. Writers call it under the folder's lock.
[[nodiscard]] Status ClaimStoreDirectory(Env* env, const std::string& dir);

// For a writer of the store `dir`: checks it (above), creates it if missing,
// takes its exclusive lock, then claims it (checked again under the lock).
// Errors: CheckStoreDirectory's, DirectoryLock's (the holder's pid), IOError.
StatusOr<DirectoryLock> OpenStoreForWriting(Env* env, const std::string& dir);

// Removes the regular files "NAME.tmp-<digits>" in `dir` and, if `recursive`,
// in its subfolders. Only for a holder of the exclusive lock on `dir`.
[[nodiscard]] Status RemoveStaleTemporaries(Env* env, const std::string& dir, bool recursive);

// True for "NAME.tmp-<digits>" with a non-empty NAME (atomic_file.h's names).
bool IsTemporaryFileName(const std::string& name);

}  // namespace graphslam::storage
