// External, bounded-memory bucketing: turns a replayable stream of
// observations into feature-complete chunks without ever holding more than a
// fixed number of observations in memory (issue 3, out of core).
//
// Two passes over the stream (an input file is read twice):
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
//     observations; when it is full it is stable-sorted by bucket and each
//     bucket's run is appended to WORK/bucket_NNNNNN.bin. Files are opened for
//     the duration of one append only, so any number of buckets works.
//   emit (BucketChunkSource::Load, chunks in order): bucket b is read back
//     whole (<= K observations), stable-sorted by (chunk, feature) -- stable,
//     so each feature's observations keep their input order -- and chunk k is
//     cut from it.
//
// The chunks are therefore identical, record for record, to those of
// InMemoryChunkSource on the same observations (tested), and memory is
//   O(poses + features) for the index + at most K + B observations
// (the buffer, or a bucket plus one chunk copy; the spill buffer is freed
// before the first bucket is read) and std::stable_sort's scratch (up to as
// many again), independent of the number of
// observations. The peak is measured by a counter
// (BucketingStats::peak_observations_in_memory), which the tests bound.
//
// Work files are scratch, not outputs: they are plain appends in WORK, which
// the caller creates, empties before a run and removes after it; a killed run
// leaves only scratch there.
//
// THREAD SAFETY: one BucketChunkSource is used by one thread (Load must be
// called with ascending indices, as WriteChunkStore does). ALLOCATION: above.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/chunk_source.h"
#include "core/problem.h"
#include "core/status.h"
#include "storage/native_log_reader.h"

namespace graphslam::partition {

// Calls the sink for every observation of the input, in input order, and
// returns its first error. Must give the same sequence every time it is called.
using ObservationReplay = std::function<Status(const storage::ObservationSink& sink)>;

struct ExternalBucketingOptions {
  int64_t max_observations_per_chunk = 4096;  // B
  int64_t buffer_observations = 1 << 20;      // K, >= B
  std::string work_dir;                       // must exist

  [[nodiscard]] Status Validate() const;
};

struct BucketingStats {
  int64_t observations = 0;
  int64_t chunks = 0;
  int64_t buckets = 0;
  int64_t spills = 0;                       // buffer flushes to bucket files
  int64_t spilled_bytes = 0;                // bytes appended to bucket files
  int64_t peak_observations_in_memory = 0;  // buffer, or bucket + chunk copy
};

// Pass 1: per-feature observation counts and lowest observing pose.
class FeatureIndex {
 public:
  // Counts `observation` (feature index >= 0; the index grows as needed).
  void Add(const core::Observation& observation);
  // Makes the index cover `num_features` features (unobserved ones count 0).
  void Resize(int32_t num_features);

  const std::vector<int32_t>& counts() const { return counts_; }
  const std::vector<int32_t>& first_pose() const { return first_pose_; }
  int64_t observations() const { return observations_; }

 private:
  std::vector<int32_t> counts_;
  std::vector<int32_t> first_pose_;
  int64_t observations_ = 0;
};

// Keeps, of a stream of observations, the few that Table 1 initialization and
// the connectivity check need (core/initialization.h): the first observation
// of every feature (it places the feature), and every observation that joins
// two pose components not yet joined through features (at most poses - 1).
// Initializing a problem whose observations are these gives the same guesses
// and the same connectivity verdict as with all observations, in
// O(poses + features) memory.
class InitializationObservations {
 public:
  void Add(const core::Observation& observation);
  // The kept observations, in input order.
  const std::vector<core::Observation>& kept() const { return kept_; }

 private:
  int32_t Find(int32_t pose);

  std::vector<int32_t> parent_;          // union-find over poses
  std::vector<int32_t> feature_anchor_;  // per feature: its first pose, -1 if unseen
  std::vector<core::Observation> kept_;
};

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

  int64_t NumChunks() const override { return static_cast<int64_t>(chunk_features_.size()); }
  // Sequential only (ascending index); reads a bucket file when `index` enters it.
  Status Load(int64_t index, core::ObservationChunk* chunk) const override;

  const BucketingStats& stats() const { return stats_; }

 private:
  BucketChunkSource() = default;
  std::string BucketPath(int64_t bucket) const;
  Status LoadBucket(int64_t bucket) const;

  ExternalBucketingOptions options_;
  std::vector<std::vector<int32_t>> chunk_features_;  // per chunk: features, ascending
  std::vector<int64_t> chunk_observations_;           // per chunk
  std::vector<int32_t> feature_chunk_;                // per feature: chunk, -1 if unobserved
  std::vector<int64_t> chunk_bucket_;                 // per chunk: its bucket
  std::vector<int64_t> bucket_observations_;          // per bucket

  // The bucket loaded last, sorted by (chunk, feature); mutable: Load is a
  // sequential cursor over the buckets behind the const ChunkSource interface.
  mutable int64_t loaded_bucket_ = -1;
  mutable std::vector<core::Observation> bucket_;
  mutable size_t bucket_cursor_ = 0;
  mutable BucketingStats stats_;
};

}  // namespace graphslam::partition
