// ObservationChunk: the unit of work of the reduce step.
//
// A chunk is feature-complete: every observation of each of its features is in
// this chunk and in no other, so each feature can be eliminated by Schur
// complement (paper Table 3) from the chunk alone. Features are sorted by global
// index and each feature's observations are contiguous:
//
//   observations[feature_begin[k] .. feature_begin[k+1]) observe features[k]
//
// The out-of-core store (storage/) reads chunks from disk; the in-memory source
// (partition/) cuts them from a Problem2d. The solver sees only ChunkSource.
//
// THREAD SAFETY: a plain value. ALLOCATION: O(observations in the chunk).
#pragma once

#include <cstdint>
#include <vector>

#include "core/problem.h"

namespace graphslam::core {

struct ObservationChunk {
  int64_t index = 0;                   // position in the source, 0-based
  std::vector<int32_t> features;       // global feature indices, ascending
  std::vector<int64_t> feature_begin;  // size features.size() + 1
  std::vector<Observation> observations;

  int64_t num_features() const { return static_cast<int64_t>(features.size()); }
  void Clear() {
    features.clear();
    feature_begin.clear();
    observations.clear();
  }
};

}  // namespace graphslam::core
