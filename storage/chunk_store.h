// Chunk store: a problem laid out on disk for the out-of-core solve
// (spec: docs/formats/chunk_store.md, version 1).
//
//   STORE/problem.graphslam     native log (native_log_reader.h) of the problem
//                               WITHOUT observations: poses, features with their
//                               guesses, pose-only constraints (odometry,
//                               motion, GPS, FIX)
//   STORE/chunks/NNNNNN.gsc     chunk k (6 decimal digits, 0-based) as written by
//                               WriteObservationChunk (observation_chunk.md)
//   STORE/MANIFEST.json         format name + version, the chunk list with counts
//                               and byte sizes, totals, the source input path
//
// Commit rule (LevelDB's CURRENT file): MANIFEST.json is removed first when a
// store is rewritten and written LAST, atomically (temp, fsync, rename, fsync
// of the directory), after every other file is durable. A directory without a
// MANIFEST.json is therefore an incomplete store and is rejected by every
// reader; a MANIFEST.json always describes files that were completely written.
//
// Consistency checked on read: the manifest's format, version (newer ->
// NotSupported), chunk names (must be exactly NNNNNN.gsc for position k), that
// totals equal the sums of the entries; on Load(k), that the chunk file exists
// (NotFound naming it), has the manifest's byte size, passes every check of
// chunk_reader.h, and that its header index, feature and observation counts
// equal the manifest's (Corruption naming the file, expected vs actual).
//
// THREAD SAFETY: DiskChunkSource::Load is const and may run concurrently for
// any chunks (it keeps no mutable state). WriteChunkStore must not run twice
// on one directory at once.
// ALLOCATION: WriteChunkStore holds one chunk at a time (plus a copy of the
// problem without its observations); DiskChunkSource holds the manifest
// (O(chunks)) and Load() one chunk file.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/chunk_source.h"
#include "core/problem.h"
#include "core/status.h"
#include "storage/chunk_writer.h"
#include "storage/env.h"

namespace graphslam::storage {

inline constexpr const char* kChunkStoreFormatName = "graphslam-chunk-store";
inline constexpr int kChunkStoreVersion = 1;
inline constexpr const char* kChunkStoreManifestName = "MANIFEST.json";
inline constexpr const char* kChunkStoreProblemName = "problem.graphslam";
inline constexpr const char* kChunkStoreChunkDirectory = "chunks";

struct ChunkStoreWriteOptions {
  ChunkWriteOptions chunk;  // compression etc. of every chunk file
  std::string source;       // the input the store was made from (manifest only)
  // Chunks made durable together (one directory fsync per group, the files'
  // fsyncs concurrent; storage/chunk_store_writer.h). Changes no byte.
  int64_t sync_group_chunks = 64;

  [[nodiscard]] Status Validate() const {
    if (sync_group_chunks < 1)
      return Status::InvalidArgument("sync_group_chunks is " + std::to_string(sync_group_chunks) +
                                     ", expected >= 1");
    return chunk.Validate();
  }
};

// One MANIFEST.json entry.
struct ChunkStoreEntry {
  std::string file;  // "NNNNNN.gsc", relative to STORE/chunks
  int64_t features = 0;
  int64_t observations = 0;
  int64_t bytes = 0;
};

// "NNNNNN.gsc" for chunk `index`.
std::string ChunkStoreFileName(int64_t index);

// Writes the store described above into `dir` (created if missing). `env` must
// not be null and must outlive the call; `chunks` is read once, in order, and
// every chunk's index must equal its position. `problem`'s observations are not
// written to problem.graphslam (they are the chunks). Errors: InvalidArgument
// (options, problem or chunk; before MANIFEST.json is written), IOError naming
// the path. On any error no MANIFEST.json exists, so the store is rejected.
[[nodiscard]] Status WriteChunkStore(Env* env, const std::string& dir,
                                     const core::Problem2d& problem,
                                     const core::ChunkSource& chunks,
                                     const ChunkStoreWriteOptions& options);

// True if `path` is a directory holding a MANIFEST.json (it may still fail to
// open if the manifest is damaged).
bool IsChunkStore(const std::string& path);

// Reads STORE/problem.graphslam (after checking that the store is complete).
// The result has no observations. NotFound / Corruption naming the file.
StatusOr<core::Problem2d> ReadChunkStoreProblem(const std::string& dir);

class DiskChunkSource : public core::ChunkSource {
 public:
  // Reads and validates STORE/MANIFEST.json. NotFound if `dir` does not exist,
  // Corruption "incomplete chunk store" if it has no MANIFEST.json, Corruption /
  // NotSupported naming the manifest and the field otherwise.
  static StatusOr<std::unique_ptr<DiskChunkSource>> Open(const std::string& dir);

  int64_t NumChunks() const override { return static_cast<int64_t>(entries_.size()); }
  // Reads STORE/chunks/NNNNNN.gsc (paranoid). Errors name the file.
  Status Load(int64_t index, core::ObservationChunk* chunk) const override;

  const std::string& dir() const { return dir_; }
  const std::string& source() const { return source_; }
  const std::vector<ChunkStoreEntry>& entries() const { return entries_; }
  int64_t total_features() const { return total_features_; }
  int64_t total_observations() const { return total_observations_; }
  int64_t total_bytes() const { return total_bytes_; }

 private:
  DiskChunkSource() = default;

  std::string dir_;
  std::string source_;
  std::vector<ChunkStoreEntry> entries_;
  int64_t total_features_ = 0;
  int64_t total_observations_ = 0;
  int64_t total_bytes_ = 0;
};

}  // namespace graphslam::storage
