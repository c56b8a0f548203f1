// RemoveAbandonedTemporaries: the temporaries a killed writer left next to a
// plain output, removed when the next writer of that output starts.
//
// WriteFileAtomically (storage/atomic_file.h) writes "<path>.tmp-<pid>" and
// renames it; kill -9 between the two leaves the temporary behind. In a
// folder of ours (a store, a job folder) the next writer removes such files
// under the folder's lock. A plain output (`-o x.g2o`, `--report r.json`,
// `--checkpoint c.json` and its companions) lives in the user's folder,
// where no lock says who owns a file, so a temporary is proved abandoned
// instead:
//
//   1. its name is "<base>.<anything>.tmp-<pid>" or "<base>.tmp-<pid>",
//      where <base> is the output's file name;
//   2. no process with that pid exists on this machine (kill(pid, 0) fails
//      with ESRCH), so it is not being written here;
//   3. nobody holds a lock on it: WriteFileAtomically holds flock(LOCK_EX)
//      on its temporary from creation to rename, so a writer elsewhere (a
//      shared folder, another pid namespace) keeps it.
//
// Only files that pass all three are removed; anything else stays. The
// number removed is returned.
//
// THREAD SAFETY: reentrant. ALLOCATION: the folder listing.
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"

namespace graphslam::storage {

StatusOr<int64_t> RemoveAbandonedTemporaries(const std::string& path);

}  // namespace graphslam::storage
