// ObservationChunk: the unit of work of the reduce step.
//
// A chunk is feature-complete: every observation of each of its features is in
// this chunk and in no other, so each feature can be eliminated by Schur
// complement (paper Table 3) from the chunk alone. Features are sorted by global
// index and each feature's observations are contiguous:
//
//   observations[feature_begin[k] .. feature_begin[k+1]) observe features[k]
//
// One template for both problem spaces (core/problem_space.h): ObservationChunk
// holds planar observations (core/problem.h), ObservationChunk3d 3-D point
// observations (core/problem_3d.h).
//
// The out-of-core store (storage/) reads chunks from disk; the in-memory source
// (partition/) cuts them from a Problem2d or Problem3d. The solver sees only
// ChunkSource / ChunkSource3d.
//
// THREAD SAFETY: a plain value. ALLOCATION: O(observations in the chunk).
#pragma once

#include <cstdint>
#include <vector>

#include "core/problem.h"
#include "core/problem_3d.h"

namespace graphslam::core {

template <class ObservationT>
struct BasicObservationChunk {
  using ObservationType = ObservationT;
  int64_t index = 0;                   // position in the source, 0-based
  std::vector<int32_t> features;       // global feature indices, ascending
  std::vector<int64_t> feature_begin;  // size features.size() + 1
  std::vector<ObservationT> observations;

  int64_t num_features() const { return static_cast<int64_t>(features.size()); }
  void Clear() {
    features.clear();
    feature_begin.clear();
    observations.clear();
  }
};

using ObservationChunk = BasicObservationChunk<Observation>;
using ObservationChunk3d = BasicObservationChunk<Point3Observation>;

}  // namespace graphslam::core
