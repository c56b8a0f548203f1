// Atomic file replacement: a file is either its old contents or its complete
// new contents, never a torn mix, even if the process dies or the disk fills
// (after LevelDB's SetCurrentFile in db/filename.cc).
//
//   1. write everything to  "<path>.tmp-<pid>"     (same directory => same fs)
//   2. Sync  (fsync: the new bytes are durable)
//   3. Close
//   4. Rename "<path>.tmp-<pid>" -> "<path>"       (atomic on POSIX)
//   5. SyncDirectory(dirname(path))                 (the rename is durable)
// Outputs that are not regular files are never replaced: "-" is standard
// output, an existing device or FIFO (or a symbolic link to one, such as
// /dev/stdout) is written in place, and a symbolic link to a regular file has
// that file replaced while the link stays. A directory is an error.
//
// If any of steps 1-4 fails, the temporary file is removed and an existing
// `path` is left byte-for-byte untouched; the first error is returned, with
// "writing <path>" as context. If step 5 fails the new file is already in place
// but its durability is unknown; that error is returned too.
//
// THREAD SAFETY: safe to call concurrently for different paths. Two writers of
// the same path in one process would share the temporary name: callers must
// not do that. ALLOCATION: whatever `writer` allocates.
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

// The output name that means standard output.
inline constexpr const char* kStandardOutput = "-";

// "<path>.tmp-<pid>": the temporary name WriteFileAtomically uses.
std::string TemporaryFileName(const std::string& path);

// Writes `path` through `writer`, which appends the contents to the file it is
// given (it must not Sync or Close it). `env` must not be null.
[[nodiscard]] Status WriteFileAtomically(Env* env, const std::string& path,
                                         const std::function<Status(WritableFile*)>& writer);

// WriteFileAtomically with a writer that appends `contents`.
[[nodiscard]] Status WriteStringAtomically(Env* env, const std::string& path,
                                           std::string_view contents);

}  // namespace graphslam::storage
