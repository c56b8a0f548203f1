// ReadObservationChunk: loads one chunk file written by chunk_writer.h
// (format: docs/formats/observation_chunk.md, layout: storage/chunk_format.h)
// and checks everything the format promises before the solver sees it. Reads
// both format versions: 1 (one record per observation) and 2 (columnar
// blocks with an information table); they decode to the same chunk.
//
// Checks, in file order: the magic number; the version (a newer one is
// NotSupported, not Corruption); the header CRC, flags and counts; for every
// record its length against the bytes left, its masked CRC32C, its type, its
// zstd frame; for every feature block that it continues where the previous one
// ended (feature slot and observation offset), that features are strictly
// ascending and non-negative, that each observation's feature is its slot's
// feature, pose >= 0, kind valid, z and information finite (version 2: the
// information table fits the block and every index is inside it); at the end a footer
// whose counts and chained CRC match what was read, and nothing after it.
//
// Every error names the file, the record (0-based, counted from the first
// record after the header) and its byte offset, and expected vs actual:
//   Corruption("00042.gsc: record 3 at byte 88412: crc mismatch
//               (expected 0x1c2f9e07, got 0x5d0e4b11)")
//   Corruption("00042.gsc: truncated at byte 4096: no footer after record 2 ...")
//
// Paranoid mode (the default) stops at the first problem and returns it. In
// non-paranoid mode (LevelDB's paranoid_checks = false) a damaged record is
// skipped, its bytes are reported through the reporter, and reading goes on
// from the next record; a record length that runs past the end of the file (or
// a truncated record header) drops the rest of the file. Because a block holds
// whole features, what survives is a valid chunk with fewer features. Header
// damage is always an error: nothing after it can be trusted.
// Invariant of a non-paranoid read that returns OK: the bytes accepted plus the
// bytes reported equal the file size.
//
// THREAD SAFETY: ReadObservationChunk may run concurrently on distinct chunks
// (and on one file); the reporter is called from the reading thread only.
// ALLOCATION: the whole file (a chunk is sized to fit in memory), one
// decompressed block, and the decoded chunk.
#pragma once

#include <cstdint>
#include <string>

#include "core/observation_chunk.h"
#include "core/status.h"

namespace graphslam::storage {

// Receives the bytes a non-paranoid read drops (LevelDB log::Reader::Reporter).
class ChunkCorruptionReporter {
 public:
  virtual ~ChunkCorruptionReporter() = default;
  // `bytes` were dropped because of `status` (a Corruption naming the file,
  // record and offset). Bytes may be 0, e.g. for a footer that is missing
  // although the file ends at a record boundary.
  virtual void Corruption(int64_t bytes, const Status& status) = 0;
};

struct ChunkReadOptions {
  // Stop at the first corruption (true) or skip damaged records and report
  // them (false).
  bool paranoid = true;
  // Where dropped bytes are reported in non-paranoid mode; null logs a
  // warning instead. Not owned; must outlive the read.
  ChunkCorruptionReporter* reporter = nullptr;
};

// Reads `path` into *chunk (not null). On OK, *chunk holds the chunk (its index
// from the header, feature_begin of size features + 1, also for an empty
// chunk). On error, *chunk is left unchanged: decoding goes to a separate
// value that replaces *chunk only at the end. Errors: NotFound (no such file),
// IOError (reading failed), NotSupported (newer version or unknown flags),
// Corruption (anything else, see the header comment).
[[nodiscard]] Status ReadObservationChunk(const std::string& path, core::ObservationChunk* chunk,
                                          const ChunkReadOptions& options = {});

}  // namespace graphslam::storage
