// The counts trailer of a native log (docs/formats/native_log.md, "Counts
// trailer"): an optional last line
//
//   # counts: poses P features F observations O [feature_ids I]
//
// (a comment to every reader) that `graphslam simulate --streaming` writes
// once the log is complete: its poses, observed features and observation
// records, and optionally I, one past the highest observed feature id when
// every id is >= 0 (the size of the readers' direct id table,
// storage/internal/id_map.h). It lets a command size its memory from exact counts before
// reading the log (tools/memory_budget.h). In a zstd log the line is a frame
// of its own after the records' frame, so it is found among the file's last
// bytes (the last zstd frame magic number from which exactly one frame
// reaches the end of the file) without decompressing the rest.
//
// THREAD SAFETY: reentrant (reads the file).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/status.h"

namespace graphslam::storage {

struct NativeLogCounts {
  int64_t poses = 0;
  int64_t features = 0;
  int64_t observations = 0;
  int64_t feature_id_end = -1;  // I; -1: not given
};

// The trailer line for `counts`, with its newline.
std::string NativeLogCountsLine(const NativeLogCounts& counts);

// The trailer of the log at `path` (plain or zstd). NotFound when its last
// line is not a counts trailer (a log written by other means); IOError
// naming the file if it cannot be read.
StatusOr<NativeLogCounts> ReadNativeLogCounts(const std::string& path);

}  // namespace graphslam::storage
