// ReplayNativeLogObservations: the second pass of the out-of-core ingest over
// a native log (docs/formats/native_log.md) that ReadNativeLogStreaming has
// already read and checked in full: only its RB / XY records, parsed in
// parallel, delivered in file order in blocks, each with the byte offset and
// line number where the next block starts (so the caller can resume there).
//
//   serial      cut the file into blocks of whole lines (~1 MiB), counting
//               lines (an observation's `line` is its line number)
//   parallel    parse the RB / XY lines of a block: ids -> dense indices
//               through the first pass's ids (problem.pose_ids /
//               feature_ids), z, information = SymmetricFromUpper2(upper)
//   serial      hand the blocks to `sink` in file order
//
// The observations are bit-identical to those ReadNativeLogStreaming gives
// (same tokens, same std::from_chars, same matrix assembly; tested). Every
// other record is skipped unparsed: the first pass checked them. A record the
// first pass would have rejected, or an id it did not declare, means the file
// changed between the passes: Corruption "<file>:<line>: ...; the file changed
// since the first pass".
//
// THREAD SAFETY: reentrant; `sink` is called from one thread at a time.
// ALLOCATION: at most kBlocksInFlight blocks of text and their observations;
// the id tables (<= 32 bytes per id, none for ids 0..n-1).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/observation_chunk.h"
#include "core/status.h"

namespace graphslam::storage {

struct NativeLogObservationBlock {
  const core::Observation* observations = nullptr;
  size_t size = 0;
  // Where the block after this one starts: byte offset of a line start, and
  // the number of lines before it. A resumed replay starts there.
  int64_t end_offset = 0;
  int32_t end_line = 0;
};

using NativeLogBlockSink = std::function<Status(const NativeLogObservationBlock&)>;

struct NativeLogReplayOptions {
  int64_t start_offset = 0;  // a line start (0, or a block's end_offset)
  int32_t start_line = 0;    // lines before start_offset
  int64_t block_bytes = int64_t{1} << 20;
  int blocks_in_flight = 8;
};

// `pose_ids` / `feature_ids` are the first pass's (ReadNativeLogStreaming on
// `path`: problem.pose_ids, problem.feature_ids; id i has dense index i).
// Errors: IOError / NotFound naming the path, Corruption as above, the sink's.
[[nodiscard]] Status ReplayNativeLogObservations(const std::string& path,
                                                 const std::vector<int64_t>& pose_ids,
                                                 const std::vector<int64_t>& feature_ids,
                                                 const NativeLogReplayOptions& options,
                                                 const NativeLogBlockSink& sink);

}  // namespace graphslam::storage
