// IndexFeatureRuns: a chunk's feature index (core/observation_chunk.h:
// `features` and `feature_begin`) read off its observations alone, when
// those already hold each feature's observations as one run, features
// ascending (a sample read in feature order, a bucket sorted by feature
// slot): a run starts wherever the feature differs from the one before,
//   features[k] = observations[feature_begin[k]].feature,
//   feature_begin[k + 1] = the first i > feature_begin[k] of another feature.
//
// THREAD SAFETY: writes *chunk only. ALLOCATION: O(features of the chunk).
#pragma once

#include <cstdint>

#include "core/observation_chunk.h"

namespace graphslam::core {

template <class ObservationT>
void IndexFeatureRuns(BasicObservationChunk<ObservationT>* chunk) {
  chunk->features.clear();
  chunk->feature_begin.clear();
  const auto& observations = chunk->observations;
  for (size_t i = 0; i < observations.size(); ++i) {
    const int32_t f = observations[i].feature;
    if (i > 0 && observations[i - 1].feature == f) continue;
    chunk->features.push_back(f);
    chunk->feature_begin.push_back(static_cast<int64_t>(i));
  }
  chunk->feature_begin.push_back(static_cast<int64_t>(observations.size()));
}

}  // namespace graphslam::core
