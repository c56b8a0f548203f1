// InMemoryChunkSource: cuts the observations of a Problem2d into
// feature-complete chunks held in memory; InMemoryChunkSource3d does the same
// for a Problem3d (one template, instantiated for both observation types).
//
// Partition rule (the same one the out-of-core store uses): features are
// ordered by the first pose that observes them, so consecutive features were
// first seen from nearby poses and a chunk touches a narrow band of poses
// (temporal locality); they are then packed greedily into chunks of at most
// `max_observations_per_chunk` observations. A feature is never split: a
// feature with more observations than the budget gets a chunk of its own.
// Inside a chunk, features are sorted by global index and each feature's
// observations keep their input order.
//
// THREAD SAFETY: Load() is const and may run concurrently.
// ALLOCATION: O(observations) once at construction (the observations held
// once, in chunk order, plus 8 bytes each while they are reordered); Load()
// copies one chunk.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "core/chunk_source.h"
#include "core/problem.h"
#include "core/problem_3d.h"

namespace graphslam::partition {

struct ChunkingOptions {
  int64_t max_observations_per_chunk = 4096;
};

template <class ObservationT>
class BasicInMemoryChunkSource : public core::BasicChunkSource<ObservationT> {
 public:
  using Chunk = core::BasicObservationChunk<ObservationT>;
  // Copies `observations` (feature indices in [0, num_features)); they need
  // not outlive this. A feature f with excluded[f] != 0 (when `excluded` is
  // not empty: one flag per feature) is left out as if unobserved, without
  // a filtered copy of the observations first.
  BasicInMemoryChunkSource(const std::vector<ObservationT>& observations, int32_t num_features,
                           const ChunkingOptions& options,
                           std::span<const uint8_t> excluded = {});
  // The same chunks from `observations` taken over and reordered in place:
  // the caller's copy is not needed, and the observations are held once
  // (a copy would double the largest part while the chunks are cut).
  BasicInMemoryChunkSource(std::vector<ObservationT>&& observations, int32_t num_features,
                           const ChunkingOptions& options,
                           std::span<const uint8_t> excluded = {});
  // The observations of a Problem2d or Problem3d.
  template <class Problem>
  BasicInMemoryChunkSource(const Problem& problem, const ChunkingOptions& options)
      : BasicInMemoryChunkSource(problem.observations, problem.num_features(), options) {}

  int64_t NumChunks() const override { return static_cast<int64_t>(chunks_.size()); }
  Status Load(int64_t index, Chunk* chunk) const override;

  // Number of observations of each feature (features never observed have 0).
  const std::vector<int64_t>& observations_per_feature() const { return per_feature_; }

 private:
  // Every kept observation in chunk order: chunk k's are
  // observations_[chunk_begin_[k] .. chunk_begin_[k + 1]); chunks_ hold the
  // features and their run starts, without observations.
  std::vector<ObservationT> observations_;
  std::vector<int64_t> chunk_begin_;
  std::vector<Chunk> chunks_;
  std::vector<int64_t> per_feature_;
};

using InMemoryChunkSource = BasicInMemoryChunkSource<core::Observation>;
using InMemoryChunkSource3d = BasicInMemoryChunkSource<core::Point3Observation>;

}  // namespace graphslam::partition
