// IngestToStore: any supported input -> chunk store (storage/chunk_store.h),
// in memory bounded by the external bucketing (external_bucketing.h).
//
//   1. un-commit: remove STORE/MANIFEST.json if there is one (fsync STORE/), and
//      empty the scratch folder STORE/work/ (unless resuming). From here until
//      step 5 ends the directory is an incomplete store that every reader
//      rejects, whatever kills the process (kill -9 included).
//   2. pass 1 over the input (beside it, in a thread, the input's size and
//      CRC32C for the progress records and the manifest; a resume computes
//      them first, to compare): the pose-only problem (poses, features, odometry,
//      motion, GPS, FIX), the FeatureIndex, and the FirstSightInitialization
//      (partition/initialization/first_sight_initialization.h: each feature's first sight
//      appended to work/first_sight.bin, the <= poses - 1 joining observations
//      kept); native logs: every observation appended to the replay frames
//      (step 4). Native logs are streamed (ReadNativeLogStreaming: O(poses +
//      features)); other formats (g2o, iSAM, MRCLAM) are read whole by their
//      readers and replayed from memory -- only the native log path is bounded.
//   3. work/pass1.bin (ids and FeatureIndex; the index is then freed), then
//      Table 1 initialization (core/initialization.h) of the pose-only problem
//      from the joining observations and the first sights read back from
//      disk: the same guesses and the same connectivity check as with every
//      observation. STORE/problem.graphslam is written now (atomically), the
//      problem freed and the FeatureIndex read back from work/pass1.bin; for
//      native logs then the first work/ingest_progress.json (stage "spill").
//   4. pass 2: spill into bucket files in STORE/work/ (BucketChunkSource);
//      native logs from the observations pass 1 parsed, kept as replay frames
//      in work/replay_NNNNNN.bin (partition/ingest/replay_frames.h: binary, zstd,
//      CRC32C; the text is read and parsed once), with a checkpoint (replay
//      position, bucket lengths) at most every checkpoint_seconds, after
//      which the replay segments it covers are deleted; then stage "chunks".
//   5. chunks in order (ChunkStoreWriter: parallel encoding, grouped fsyncs),
//      a checkpoint after every durable group;
//   6. native logs with SCAN records: their .pcd files into STORE/scans/
//      (partition/ingest/ingest_scans.h; records kept by pass 1 in
//      work/scan_records.bin, a checkpoint per durable scan chunk);
//      MANIFEST.json last; then STORE/work/ is removed.
//   --resume after a kill: from the recorded stage and position (formats:
//   docs/formats/ingest_progress.md); the store is byte-identical to an
//   uninterrupted ingest's (tested with kill -9 at several points).
//
// The store equals the one the in-memory path (InMemoryChunkSource +
// WriteChunkStore) writes for the same input and chunk size, byte for byte in
// problem.graphslam and record for record in every chunk (tested).
//
// THREAD SAFETY: one ingest per STORE at a time. ALLOCATION: O(poses +
// features) + at most buffer_observations + max_observations_per_chunk
// observations (summary->bucketing.peak_observations_in_memory) for native
// logs, plus the counting sorts' scratch (up to as many again). Nothing per
// observation. What stays per observed feature, and why (resident bytes;
// docs/out_of_core.md "Memory per feature"):
//   pass 1, while the log is read: the feature's id (8), the FeatureIndex
//     (count + lowest pose, 8), the reader's line of first use (~1.2,
//     varints of the gaps: storage/internal/monotone_lines.h) and declared
//     flag (1 bit), for its error messages and the FEATURE-record rules, and
//     its id -> index table (direct int32 table over the id range: ~7-13 B
//     at the simulator's 1.7-3.3 ids per observed feature). ~17.5 B + 4 B
//     per id. The guesses are not held (a log without FEATURE guesses has
//     none to hold) and the first sight (72 B) is on disk.
//   pass 1, after the read: the reader's state freed and the FeatureIndex
//     written to work/pass1.bin, the guess (16), id (8) and initialized flag
//     (1), 25 B, through the initialization (whose union-find covers the
//     poses and the <= poses - 1 joining features only) and until
//     problem.graphslam is written.
//   pass 2: the plan (chunk + slot per feature, and each chunk's feature
//     list: 12), made from the FeatureIndex read back (8) and freed after
//     it. The problem and the ids are not held (the replay frames hold
//     dense indices: no id table).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/status.h"
#include "partition/ingest/external_bucketing.h"
#include "partition/ingest/ingest_scans.h"
#include "partition/ingest/replay_frames.h"
#include "storage/chunk_store.h"
#include "storage/env.h"
#include "storage/format_detection.h"
#include "storage/native_log_reader.h"

namespace graphslam::partition {

inline constexpr const char* kIngestWorkDirectory = "work";

// The processes of a distributed ingest (`mpirun -np N graphslam ingest`,
// docs/distributed.md): every rank reads the input and plans the same chunks
// (pass 1 in its own STORE/work.rank-R/; rank 0 in STORE/work/), spills the
// observations of the buckets its shard -- chunks [floor(r K / N),
// floor((r + 1) K / N)) of the K chunks -- is cut from (the others' it
// skips), writes its shard into STORE/chunks/, and rank 0,
// which alone claims and un-commits the store and writes the problem file
// and the scans, commits the manifest listing every chunk and the shards.
// The chunk files are those one process writes (the plan and the encoding
// are pure functions of the input and the options).
struct IngestRanks {
  int rank = 0;
  int size = 1;
  // Collective: returns once every rank called it.
  std::function<void()> barrier;
  // Collective: every rank's shard entries to rank 0, which gets all chunks'
  // entries in chunk order and the shards (others: left as they are).
  std::function<Status(std::vector<storage::ChunkStoreEntry>* entries,
                       std::vector<storage::ChunkStoreShard>* shards)>
      gather;
};

struct StreamingIngestOptions {
  storage::InputFormat format = storage::InputFormat::kNative;
  storage::MrclamOptions mrclam;
  int64_t max_observations_per_chunk = 4096;  // B
  int64_t buffer_observations = 1 << 20;      // K
  // A native log's sizes from its counts trailer (storage/native_log_counts.h),
  // if known: pass 1 reserves its per-feature arrays to them
  // (storage/native_log_reader.h ReadNativeLogStreaming).
  storage::ExpectedSizes expected;
  storage::ChunkStoreWriteOptions store;
  // Continue an interrupted ingest of the same input with the same options
  // from STORE/work/ (partition/ingest/ingest_progress.h); without a usable record
  // the ingest starts afresh (and says so in the log). Native logs only:
  // other formats always start afresh.
  bool resume = false;
  // Least time between two pass-2 checkpoints (each fsyncs the bucket files
  // appended since the last); 0: at every buffer spill.
  double checkpoint_seconds = 30.0;
  // How pass 1 keeps its observations for pass 2 (partition/ingest/replay_frames.h;
  // a checkpoint falls between frames).
  ReplayFrameOptions replay;
  // Copy a native log's SCAN .pcd files into STORE/scans/ (partition/ingest/ingest_scans.h),
  // in chunk files of about scan_chunk_bytes. `solve FILE --workdir` does not:
  // the solver needs no scans.
  bool copy_scans = true;
  int64_t scan_chunk_bytes = int64_t{16} << 20;
  // Several processes writing one store (above); default: this one alone.
  // No resume then.
  IngestRanks ranks;
};

struct IngestSummary {
  int32_t poses = 0;
  int32_t features = 0;
  int64_t observations = 0;
  int64_t chunks = 0;
  bool streamed = false;  // pass 1 and 2 streamed the file (native log)
  // Where a resumed ingest continued: "" (it started afresh), "spill"
  // (pass 2, after resumed_from_observation replayed observations) or
  // "chunks" (after resumed_from_chunk durable chunks).
  std::string resumed_stage;
  int64_t resumed_from_observation = 0;
  int64_t resumed_from_chunk = 0;
  BucketingStats bucketing;
  // Pass 1's observations kept for pass 2 (native logs): bytes of replay
  // frames written by pass 1 (0 if resumed past it) and read by pass 2.
  int64_t replay_bytes_written = 0;
  int64_t replay_bytes_read = 0;
  ScanIngestSummary scans;  // the log's SCAN records copied into STORE/scans/
};

// `store_dir` must be missing, empty or a store of ours (storage/
// store_directory.h; InvalidArgument naming it otherwise, before anything is
// written); the caller holds its exclusive lock (OpenStoreForWriting).
// Errors: the readers' (file:line), InvalidArgument from initialization or the
// options, IOError naming the path. On error no MANIFEST.json exists.
[[nodiscard]] Status IngestToStore(storage::Env* env, const std::string& input,
                                   const std::string& store_dir,
                                   const StreamingIngestOptions& options, IngestSummary* summary);

}  // namespace graphslam::partition
