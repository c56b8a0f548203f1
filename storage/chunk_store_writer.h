// ChunkStoreWriter: writes a chunk store (docs/formats/chunk_store.md) in
// steps, so that a long writer (the out-of-core ingest) can record its
// progress and resume; WriteChunkStore (chunk_store.h) is the one-call form.
//
//   Uncommit      remove MANIFEST.json (fsync STORE/), create STORE/chunks/
//   WriteProblem  STORE/problem.graphslam, atomically (atomic_file.h)
//   WriteChunks   chunk files [first, n) in a bounded TBB pipeline:
//                   load (serial, in order) -> encode (parallel: validate,
//                   build the bytes, zstd) -> write (serial, in order)
//                 The bytes of every chunk are those of WriteObservationChunk,
//                 whatever the number of threads (encoding is a pure function
//                 of the chunk). Durability is grouped: a chunk is written to
//                 its temporary file without fsync; every `sync_group_chunks`
//                 chunks the group's files are fsynced (concurrently, so the
//                 file system can fold the journal commits), renamed to their
//                 names, and STORE/chunks/ is fsynced once -- the same
//                 temp-fsync-rename-fsync(dir) protocol as WriteFileAtomically,
//                 with one directory fsync per group instead of two fsyncs per
//                 chunk (at 10^6 features: 924 chunks, ~1850 fsyncs before).
//                 After each group `on_durable(k)` says chunks [0, k) are
//                 durable under their final names.
//   RecoverEntries  for a resumed writer: the manifest entries of chunks
//                 [0, k) already on disk, from their 48-byte headers and sizes.
//   WriteChunkShard  chunks [first, end) only, as WriteChunks writes them:
//                 one MPI rank's shard of a distributed ingest
//                 (docs/distributed.md); entries() then holds its entries.
//   SetEntries    the entries of every shard and the shards, gathered on the
//                 rank that commits.
//   Commit        MANIFEST.json, atomically: from here the store opens; then
//                 chunk files of an older, longer store (numbers >= the new
//                 count) are removed.
//
// Before Commit the directory is an incomplete store that every reader
// rejects, whatever kills the process.
//
// THREAD SAFETY: one writer per STORE; WriteChunks uses TBB and up to
// kMaxSyncThreads short-lived threads for the group fsyncs. ALLOCATION: at
// most kChunksInFlight chunks and their encoded bytes, one group of open files
// (64 KiB buffer each), and the manifest entries (O(chunks)).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/chunk_source.h"
#include "core/problem.h"
#include "core/status.h"
#include "storage/chunk_store.h"
#include "storage/env.h"

namespace graphslam::storage {

class ChunkStoreWriter {
 public:
  static constexpr int kChunksInFlight = 8;
  static constexpr int kMaxSyncThreads = 16;

  // `env` must outlive the writer.
  ChunkStoreWriter(Env* env, std::string dir, ChunkStoreWriteOptions options);

  [[nodiscard]] Status Uncommit();
  [[nodiscard]] Status WriteProblem(const core::Problem2d& problem);
  // Writes chunks [first, chunks.NumChunks()); entries [0, first) must be
  // known (RecoverEntries) when first > 0. `on_durable` may be empty.
  [[nodiscard]] Status WriteChunks(const core::ChunkSource& chunks, int64_t first,
                                   const std::function<Status(int64_t)>& on_durable);
  // Corruption naming the file if a chunk's header is damaged, its index is
  // not its position, or the file is missing.
  [[nodiscard]] Status RecoverEntries(int64_t count);
  // Writes chunks [first, end) of `chunks` (whose other chunks another writer
  // writes into the same STORE/chunks/); entries() becomes theirs.
  [[nodiscard]] Status WriteChunkShard(const core::ChunkSource& chunks, int64_t first,
                                       int64_t end);
  // All chunks' entries (in chunk order) and the shards that wrote them, for
  // Commit (which lists the shards in the manifest).
  void SetEntries(std::vector<ChunkStoreEntry> entries, std::vector<ChunkStoreShard> shards);
  [[nodiscard]] Status Commit();
  // The input's identity for the manifest, when it is known only after the
  // writer was made (the ingest checksums the input beside its first pass).
  void SetInput(const FileChecksum& input) { options_.input = input; }

  const std::vector<ChunkStoreEntry>& entries() const { return entries_; }

 private:
  Env* const env_;
  const std::string dir_;
  ChunkStoreWriteOptions options_;
  // Chunks [first, end) of `chunks`, appended to entries_.
  [[nodiscard]] Status WriteRange(const core::ChunkSource& chunks, int64_t first, int64_t end,
                                  const std::function<Status(int64_t)>& on_durable);

  std::vector<ChunkStoreEntry> entries_;
  std::vector<ChunkStoreShard> shards_;
};

}  // namespace graphslam::storage
