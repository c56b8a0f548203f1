// Chunk store: a problem laid out on disk for the out-of-core solve
// (spec: docs/formats/chunk_store.md, version 2; version 1 is read with a
// warning).
//
//   STORE/problem.graphslam     native log (native_log_reader.h) of the problem
//                               WITHOUT observations: poses, features with their
//                               guesses, pose-only constraints (odometry,
//                               motion, GPS, FIX)
//   STORE/chunks/NNNNNN.gsc     chunk k (6 decimal digits, 0-based) as written by
//                               WriteObservationChunk (observation_chunk.md)
//   STORE/MANIFEST.json         format name + version, the chunk list with counts,
//                               byte sizes and CRC32Cs, the other files (problem,
//                               scans) with sizes and CRC32Cs, totals, the input's
//                               path and identity (size, CRC32C), and the
//                               manifest's own CRC32C over all of that
//
// Commit rule (LevelDB's CURRENT file): MANIFEST.json is removed first when a
// store is rewritten and written LAST, atomically (temp, fsync, rename, fsync
// of the directory), after every other file is durable. A directory without a
// MANIFEST.json is therefore an incomplete store and is rejected by every
// reader; a MANIFEST.json always describes files that were completely written.
//
// Consistency checked on read: the manifest's own checksum (any edit, e.g. a
// chunk entry removed or a digit changed, is Corruption naming it), format,
// version (newer -> NotSupported), that every listed file exists with its
// size; the problem file's CRC32C when it is read, each chunk file's CRC32C on
// its first Load; chunk names (must be exactly NNNNNN.gsc for position k), that
// totals equal the sums of the entries; on Load(k), that the chunk file exists
// (NotFound naming it), has the manifest's byte size, passes every check of
// chunk_reader.h, and that its header index, feature and observation counts
// equal the manifest's (Corruption naming the file, expected vs actual).
//
// THREAD SAFETY: DiskChunkSource::Load is const and may run concurrently for
// any chunks (its only mutable state is an atomic "CRC checked" flag per
// chunk). WriteChunkStore must not run twice on one directory at once: the
// commands take the store's exclusive lock (storage/store_directory.h).
// ALLOCATION: WriteChunkStore holds one chunk at a time (plus a copy of the
// problem without its observations); DiskChunkSource holds the manifest
// (O(chunks)) and Load() one chunk file.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <vector>

#include "core/chunk_source.h"
#include "core/problem.h"
#include "core/status.h"
#include "storage/chunk_writer.h"
#include "storage/env.h"
#include "storage/file_checksum.h"

namespace graphslam::storage {

inline constexpr const char* kChunkStoreFormatName = "graphslam-chunk-store";
// 2: CRC32Cs of every file, the input's identity, the manifest's own
// checksum. Version 1 stores are still read, with a warning that their
// files are not checksummed.
inline constexpr int kChunkStoreVersion = 2;
inline constexpr const char* kChunkStoreManifestName = "MANIFEST.json";
inline constexpr const char* kChunkStoreProblemName = "problem.graphslam";
inline constexpr const char* kChunkStoreChunkDirectory = "chunks";
// `graphslam solve STORE`'s checkpoint (and its ".candidates.bin" /
// ".ids.bin" companions); a rewrite of the store removes them.
inline constexpr const char* kChunkStoreCheckpointName = "checkpoint.json";

struct ChunkStoreWriteOptions {
  ChunkWriteOptions chunk;  // compression etc. of every chunk file
  std::string source;       // the input the store was made from (manifest only)
  // Its identity (storage/file_checksum.h IdentifyInput); bytes < 0: unknown.
  FileChecksum input{-1, 0};
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
  uint32_t crc32c = 0;  // of the whole file (version >= 2)
};

// A MANIFEST.json "shards" entry: the chunks one MPI rank of a distributed
// ingest wrote (`mpirun -np N graphslam ingest`, docs/distributed.md):
// chunks [first_chunk, first_chunk + chunks). Shards are listed by rank
// 0..N-1 and cover the chunks in order; a one-process ingest lists none.
// They say who wrote what: any number of ranks reads any store.
struct ChunkStoreShard {
  int rank = 0;
  int64_t first_chunk = 0;
  int64_t chunks = 0;
};

// A MANIFEST.json "files" entry: problem.graphslam, scans/... (version >= 2).
struct ChunkStoreFile {
  std::string path;  // relative to STORE, '/'-separated, no ".."
  int64_t bytes = 0;
  uint32_t crc32c = 0;
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

// Reads STORE/problem.graphslam (after opening the manifest and checking the
// file's size and CRC32C against it). The result has no observations;
// without `with_features`, no features either (ReadNativeLogWithoutFeatures).
// The features are read without an id table, into arrays reserved to the
// manifest's total_features (ExpectedSizes::declared_once): ~25 B per
// feature while the file is read. NotFound / Corruption naming the file.
StatusOr<core::Problem2d> ReadChunkStoreProblem(const std::string& dir,
                                                bool with_features = true);

// Checks the CRC32C of every manifest "files" entry whose path starts with
// `prefix` (e.g. "scans/"). Corruption naming the file. Version 1: nothing.
[[nodiscard]] Status VerifyChunkStoreFiles(const std::string& dir, const std::string& prefix);

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
  int version() const { return version_; }
  // The input's identity as recorded; bytes < 0 if unknown (version 1).
  const FileChecksum& input() const { return input_; }
  const std::vector<ChunkStoreFile>& files() const { return files_; }
  const std::vector<ChunkStoreEntry>& entries() const { return entries_; }
  const std::vector<ChunkStoreShard>& shards() const { return shards_; }
  int64_t total_features() const { return total_features_; }
  int64_t total_observations() const { return total_observations_; }
  int64_t total_bytes() const { return total_bytes_; }

 private:
  DiskChunkSource() = default;
  // "input" and "files" of a version 2 manifest, and the files' sizes.
  [[nodiscard]] Status ReadVersion2Fields(const nlohmann::json& manifest, const std::string& path);

  std::string dir_;
  std::string source_;
  int version_ = 0;
  FileChecksum input_{-1, 0};
  std::vector<ChunkStoreEntry> entries_;
  std::vector<ChunkStoreShard> shards_;
  std::vector<ChunkStoreFile> files_;
  // Per chunk: 1 once its CRC32C matched (checked on the first Load only:
  // the chunk format's own record CRCs check every later read).
  std::unique_ptr<std::atomic<uint8_t>[]> checked_;
  int64_t total_features_ = 0;
  int64_t total_observations_ = 0;
  int64_t total_bytes_ = 0;
};

}  // namespace graphslam::storage
