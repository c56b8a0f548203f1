// The out-of-core parts of `graphslam solve` (docs/out_of_core.md):
//
//   --workdir DIR     a FILE input is first ingested into the chunk store DIR
//                     (partition/ingest/streaming_ingest.h: bounded memory for native
//                     logs) and solved from there; DIR is kept (checkpoints
//                     land in DIR/checkpoint.json, so --resume works). Without
//                     --workdir a FILE is solved in memory, as before.
//   streaming mode    a chunk store with more poses than streaming_poses,
//                     or more observations than streaming_observations or
//                     than the sampled start's budget B, is solved without
//                     loading its observations, from the sampled incremental
//                     start (partition/initialization/
//                     sampled_incremental_initialization.h) instead of the
//                     in-memory one on every observation.
//   --memory-limit    the budget of the ingest and the solve
//                     (tools/memory_budget.h): a limit below the estimated
//                     need is refused before anything is read.
//
// THREAD SAFETY: pure functions plus one ingest. ALLOCATION: see the ingest.
#pragma once

#include <cstdint>
#include <string>

#include "core/status.h"

namespace graphslam::tools {

// True if `workdir` holds a complete chunk store ingested from `input` (the
// manifest's source) whose recorded input identity (size and CRC32C,
// storage/file_checksum.h) is that of `input` now: `solve FILE --workdir DIR
// --resume` then reuses it instead of ingesting again, so the checkpoint in
// DIR matches the store it was made on. An mtime is not trusted: a replaced
// file can keep it. Version 1 stores (no identity) are never current.
bool WorkdirStoreIsCurrent(const std::string& input, const std::string& workdir);

// Ingests `input` (format "auto" or a name) into the store `workdir` with
// `chunk_observations` per chunk; `resume` continues an interrupted ingest
// (partition/ingest/streaming_ingest.h). Errors from detection, readers, the ingest.
[[nodiscard]] Status IngestIntoWorkdir(const std::string& input, const std::string& format,
                                       int robot, const std::string& workdir,
                                       int64_t chunk_observations, int64_t memory_limit_bytes,
                                       bool resume = false);

}  // namespace graphslam::tools
