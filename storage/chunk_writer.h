// WriteObservationChunk: stores one core::ObservationChunk as a chunk file
// (format: docs/formats/observation_chunk.md, layout: storage/chunk_format.h).
//
// The chunk's features are cut into feature blocks of whole features, each
// at most about `target_record_bytes` before compression, each one framed record
//
//   [length u32][type u8][masked crc32c u32][payload]
//
// optionally zstd-compressed (a block is stored compressed only when that makes
// it smaller), between a header (magic, version, flags, chunk index, counts)
// and a footer (counts, number of blocks, a CRC chained over every record) so a
// reader detects damage, truncation, and missing or reordered records.
//
// The chunk is validated before any file is touched (InvalidArgument naming
// the path, the feature slot or observation, expected vs actual): features
// strictly ascending and non-negative, feature_begin of size features + 1,
// starting at 0, monotone and ending at observations.size() (an empty chunk may
// also have an empty feature_begin), every observation's feature equal to its
// slot's feature, pose >= 0, kind valid, z and information finite.
// The write is atomic (storage/atomic_file.h): temp file, fsync, rename, fsync
// of the directory; on failure an existing file at `path` is left untouched and
// the temporary is removed.
//
// THREAD SAFETY: safe to call concurrently for different paths.
// ALLOCATION: one block (about target_record_bytes, plus its compressed copy)
// at a time; the file is streamed to the Env block by block.
#pragma once

#include <cstdint>
#include <string>

#include "core/observation_chunk.h"
#include "core/status.h"
#include "storage/chunk_format.h"
#include "storage/env.h"

namespace graphslam::storage {

enum class ChunkCompression : uint8_t {
  kNone = 0,
  kZstd = 1,  // per block, kept only where it saves space
};

struct ChunkWriteOptions {
  ChunkCompression compression = ChunkCompression::kNone;
  // zstd level, in [ZSTD_minCLevel(), ZSTD_maxCLevel()] (negative = faster).
  // 2: on feature blocks about the size of level 3 (~1 % larger) and decoded
  // as fast, for ~1/4 less compression time; level 1 is faster again but
  // ~10 % larger, which every streaming pass of a solve would read.
  int zstd_level = 2;
  // Uncompressed size a block grows to before a new one starts; a block always
  // holds at least one feature. In [1, chunk_format::kMaxRecordLength].
  int64_t target_record_bytes = int64_t{1} << 20;
  // The format version written: chunk_format::kFormatVersion (columnar
  // blocks), or 1 (one 61-byte record per observation) for readers built
  // before version 2.
  uint32_t format_version = chunk_format::kFormatVersion;

  // InvalidArgument naming the offending option and its allowed range.
  [[nodiscard]] Status Validate() const;
};

// OK, or InvalidArgument describing the first violated invariant of `chunk`
// (the list in the header comment), e.g. "observation 17 (feature slot 3):
// feature is 9, expected 12 (the feature of its slot)".
[[nodiscard]] Status ValidateObservationChunk(const core::ObservationChunk& chunk);

// Writes `chunk` to `path` atomically. `env` must not be null (use
// Env::Default()); it must outlive the call. Errors: InvalidArgument (options
// or chunk, nothing written), IOError from the Env with "writing <path>".
[[nodiscard]] Status WriteObservationChunk(Env* env, const std::string& path,
                                           const core::ObservationChunk& chunk,
                                           const ChunkWriteOptions& options = {});

// The bytes WriteObservationChunk would write for `chunk`, into *out (not
// null; replaced), for writers that encode in parallel and write in order
// (storage/chunk_store_writer.h). Same errors as WriteObservationChunk,
// without the path; nothing is touched on disk.
[[nodiscard]] Status EncodeObservationChunk(const core::ObservationChunk& chunk,
                                            const ChunkWriteOptions& options, std::string* out);

}  // namespace graphslam::storage
