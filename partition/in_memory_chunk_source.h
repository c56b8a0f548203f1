// InMemoryChunkSource: cuts the observations of a Problem2d into
// feature-complete chunks held in memory.
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
// ALLOCATION: O(observations) once at construction; Load() copies one chunk.
#pragma once

#include <cstdint>
#include <vector>

#include "core/chunk_source.h"
#include "core/problem.h"

namespace graphslam::partition {

struct ChunkingOptions {
  int64_t max_observations_per_chunk = 4096;
};

class InMemoryChunkSource : public core::ChunkSource {
 public:
  // Copies the observations of `problem`; the problem need not outlive this.
  InMemoryChunkSource(const core::Problem2d& problem, const ChunkingOptions& options);

  int64_t NumChunks() const override { return static_cast<int64_t>(chunks_.size()); }
  Status Load(int64_t index, core::ObservationChunk* chunk) const override;

  // Number of observations of each feature (features never observed have 0).
  const std::vector<int64_t>& observations_per_feature() const { return per_feature_; }

 private:
  std::vector<core::ObservationChunk> chunks_;
  std::vector<int64_t> per_feature_;
};

}  // namespace graphslam::partition
