// External, bounded-memory bucketing: turns a replayable stream of
// observations into feature-complete chunks without ever holding more than a
// fixed number of observations in memory (issue 3, out of core).
//
// Two passes over the stream (the ingest of a native log replays pass 1's
// parsed observations for pass 2, partition/ingest/replay_frames.h):
//
//   pass 1 (FeatureIndex): per feature, its number of observations n_f and the
//     lowest pose that observes it p_f -- O(features) integers, nothing per
//     observation. From these, the SAME plan as InMemoryChunkSource
//     (in_memory_chunk_source.h): features ordered by p_f (stable, so ties
//     keep index order -- temporal locality: features first seen from nearby
//     poses share a chunk), packed greedily into chunks of at most B
//     observations, a feature never split. Consecutive chunks are then grouped
//     into buckets of at most K observations (K = buffer_observations >= B;
//     a chunk larger than K, i.e. one feature with more than K observations,
//     is a bucket of its own).
//   pass 2 (spill): observations are appended to an in-memory buffer of K
//     observations; when it is full it is grouped by bucket (a counting sort:
//     stable, O(K)) and each bucket's run is appended to
//     WORK/bucket_NNNNNN.bin as one spill frame (partition/ingest/spill_frames.h:
//     61-byte columns, zstd, CRC32C; ~3x less I/O than the 72-byte structs;
//     the runs are compressed in parallel and appended by a background job
//     while the buffer fills again; the next spill waits for it). Files are
//     opened for the duration of one append only, so any number of buckets
//     works. Where the buffer is cut does not matter: a bucket file is its
//     bucket's observations in input order.
//   emit (BucketChunkSource::Load, chunks in order): bucket b is read back
//     whole (<= K observations), grouped by (chunk, feature) -- stable
//     counting sorts, by chunk and then each chunk's run by feature slot,
//     in parallel, so each feature's observations keep their input order
//     whatever the threads -- and chunk k is cut from it.
//
// The chunks are therefore identical, record for record, to those of
// InMemoryChunkSource on the same observations (tested), and memory is
//   O(poses + features) for the index + at most K + B observations
// (the buffer, or a bucket plus one chunk copy; the spill buffer is freed
// before the first bucket is read) and the counting sorts' scratch (as many
// again), independent of the number of
// observations. The peak is measured by a counter
// (BucketingStats::peak_observations_in_memory), which the tests bound.
//
// Work files are scratch, not outputs: they are plain appends in WORK, which
// the caller creates, empties before a run and removes after it; a killed run
// leaves only scratch there, which a resumed run (Spill from a SpillProgress)
// truncates back to the last checkpoint (a frame boundary, found from the
// frame headers: the progress counts observations, not bytes).
//
// THREAD SAFETY: one BucketChunkSource is used by one thread (Load must be
// called with ascending indices, as WriteChunkStore does). ALLOCATION: above.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "core/chunk_source.h"
#include "core/problem.h"
#include "core/status.h"
#include "partition/ingest/spill_frames.h"
#include "storage/native_log_reader.h"

namespace graphslam::partition {

// Calls the sink for every observation of the input, in input order, and
// returns its first error. Must give the same sequence every time it is called.
using ObservationReplay = std::function<Status(const storage::ObservationSink& sink)>;

struct ExternalBucketingOptions {
  int64_t max_observations_per_chunk = 4096;  // B
  int64_t buffer_observations = 1 << 20;      // K, >= B
  std::string work_dir;                       // must exist
  // zstd level of the bucket files' frames (partition/ingest/spill_frames.h).
  int spill_zstd_level = kSpillFrameZstdLevel;

  [[nodiscard]] Status Validate() const;
};

struct BucketingStats {
  int64_t observations = 0;
  int64_t chunks = 0;
  int64_t buckets = 0;
  int64_t spills = 0;                       // buffer flushes to bucket files
  int64_t spilled_bytes = 0;                // bytes appended to bucket files (frames)
  int64_t spilled_raw_bytes = 0;            // the same observations as 72-byte structs
  int64_t peak_observations_in_memory = 0;  // buffer, or bucket + chunk copy
};

// Pass 1: per-feature observation counts and lowest observing pose.
class FeatureIndex {
 public:
  // Counts `observation` (feature index >= 0; the index grows as needed).
  void Add(const core::Observation& observation);
  // Makes the index cover `num_features` features (unobserved ones count 0).
  void Resize(int32_t num_features);
  // Capacity for `num_features` (a log's counts trailer): the arrays then
  // never grow by copying (old and new both resident for a moment).
  void Reserve(int64_t num_features);
  // An index recorded earlier (partition/ingest/ingest_progress.h, resumed ingest).
  void Assign(std::vector<int32_t> counts, std::vector<int32_t> first_pose, int64_t observations) {
    GS_CHECK(counts.size() == first_pose.size());
    counts_ = std::move(counts);
    first_pose_ = std::move(first_pose);
    observations_ = observations;
  }

  // Moves the arrays out (to be written to disk); the index is empty after.
  void Release(std::vector<int32_t>* counts, std::vector<int32_t>* first_pose) {
    *counts = std::move(counts_);
    *first_pose = std::move(first_pose_);
    counts_.clear();
    first_pose_.clear();
  }

  const std::vector<int32_t>& counts() const { return counts_; }
  const std::vector<int32_t>& first_pose() const { return first_pose_; }
  int64_t observations() const { return observations_; }

 private:
  std::vector<int32_t> counts_;
  std::vector<int32_t> first_pose_;
  int64_t observations_ = 0;
};

// A block of observations of pass 2, in input order, and where the replay
// stands after it (end_offset: the replay's resume position, e.g. the number
// of observations replayed, partition/ingest/replay_frames.h; < 0: not a resumable
// point).
struct ObservationBlock {
  const core::Observation* observations = nullptr;
  size_t size = 0;
  int64_t end_offset = -1;
};
using ObservationBlockSink = std::function<Status(const ObservationBlock&)>;
// Calls the sink for every block from the resume point on, in input order.
using ObservationBlockReplay = std::function<Status(const ObservationBlockSink& sink)>;

// A per-observation replay as blocks of up to 4096 observations, none of
// them a resumable point (for inputs read whole). `replay` must outlive the
// result.
ObservationBlockReplay InBlocks(const ObservationReplay& replay);

// How far pass 2 got: every observation of the replay before resume
// position `replay_position` (a block's end_offset) is in the bucket files,
// which hold `bucket_observations[b]` observations each (durable when
// reported to a SpillCheckpoint). The resume point of an interrupted spill.
struct SpillProgress {
  int64_t replay_position = 0;
  int64_t observations = 0;
  std::vector<int64_t> bucket_observations;
};
// Called after a spill that ended at a resumable point, once the bucket files
// are fsynced; an error stops the spill.
using SpillCheckpoint = std::function<Status(const SpillProgress&)>;

// The chunks of the plan above, built from bucket files in WORK.
class BucketChunkSource : public core::ChunkSource {
 public:
  // Pass 2: spills `replay`'s observations into bucket files in
  // options.work_dir, following the plan made from `index`. Errors: the
  // replay's, IOError naming the bucket file, Corruption if the replay gives
  // a different sequence than pass 1 (counts differ).
  static StatusOr<std::unique_ptr<BucketChunkSource>> Build(const FeatureIndex& index,
                                                            const ObservationReplay& replay,
                                                            const ExternalBucketingOptions& options);

  // The plan alone (no file is touched); then Spill, or, when the bucket
  // files are complete already (a resumed ingest past pass 2), Load directly.
  static StatusOr<std::unique_ptr<BucketChunkSource>> Plan(const FeatureIndex& index,
                                                           const ExternalBucketingOptions& options);
  // Pass 2 from `*progress` (all zero: from the start; else the bucket files
  // are first truncated back to progress->bucket_observations, dropping what
  // a killed run appended after its last checkpoint). Updates *progress.
  // Checkpoints are taken after a buffer spill at a block boundary when at
  // least `checkpoint_seconds` passed since the last one (0: every such
  // spill); with an empty `checkpoint`, none. On OK every bucket file is
  // complete and fsynced.
  [[nodiscard]] Status Spill(const ObservationBlockReplay& replay, SpillProgress* progress,
                             const SpillCheckpoint& checkpoint, double checkpoint_seconds);

  // Makes Spill keep only the buckets holding chunks [first, end) (each
  // bucket is read back whole, so a bucket that holds chunks on both sides is
  // spilled by both callers): an ingest on MPI ranks spills only what its
  // shard's chunks need (partition/ingest/streaming_ingest.h). Only those chunks
  // may be loaded then. Default: every bucket.
  void RestrictSpillToChunks(int64_t first, int64_t end);

  int64_t NumChunks() const override { return static_cast<int64_t>(chunk_features_.size()); }
  int64_t NumBuckets() const { return static_cast<int64_t>(bucket_observations_.size()); }
  // Ascending indices (any start: a resumed writer starts mid-way); reads a
  // bucket file when `index` enters it.
  Status Load(int64_t index, core::ObservationChunk* chunk) const override;
  // Deletes the bucket files all of whose chunks lie before `chunk` (they are
  // durable in the store): frees disk as the store grows.
  void ReleaseBucketsBefore(int64_t chunk);

  const BucketingStats& stats() const { return stats_; }

 private:
  BucketChunkSource() = default;
  std::string BucketPath(int64_t bucket) const;
  Status LoadBucket(int64_t bucket) const;
  Status GroupByChunkAndFeature(const std::string& path, int64_t bucket) const;

  ExternalBucketingOptions options_;
  std::vector<std::vector<int32_t>> chunk_features_;  // per chunk: features, ascending
  std::vector<int64_t> chunk_observations_;           // per chunk
  std::vector<int64_t> chunk_offset_;                 // per chunk: first observation in its bucket
  std::vector<int64_t> chunk_slot_;                   // per chunk: first feature slot in its bucket
  std::vector<int32_t> feature_chunk_;                // per feature: chunk, -1 if unobserved
  std::vector<int32_t> feature_slot_;                 // per feature: position in its chunk
  std::vector<int64_t> chunk_bucket_;                 // per chunk: its bucket
  std::vector<int64_t> bucket_observations_;          // per bucket
  std::vector<int64_t> bucket_first_chunk_;           // per bucket
  int64_t released_buckets_ = 0;                      // bucket files [0, this) deleted
  int64_t spill_first_bucket_ = 0;                    // Spill keeps buckets [first, end)
  int64_t spill_end_bucket_ = -1;                     // -1: every bucket

  // The bucket loaded last, sorted by (chunk, feature); mutable: Load is a
  // sequential cursor over the buckets behind the const ChunkSource interface.
  mutable int64_t loaded_bucket_ = -1;
  mutable std::vector<core::Observation> bucket_;
  // LoadBucket's file bytes and decoded observations (input order), kept
  // between loads so that their pages are reused.
  mutable std::vector<char> raw_;
  mutable std::vector<core::Observation> read_;
  mutable BucketingStats stats_;
};

}  // namespace graphslam::partition
