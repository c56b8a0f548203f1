// IndexFeatureRuns (core/chunk_feature_runs.h): the
// features and their run starts read off feature-grouped observations equal
// the ones a chunk was built with, feature by feature, for random runs,
// single observations, one run only and no observation; calling it again
// replaces the index rather than appending to it.
#include "core/chunk_feature_runs.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <vector>

namespace graphslam::core {
namespace {

// A chunk built the other way round: features chosen first (ascending,
// with gaps), then `runs[k]` observations of features[k] appended.
template <class Chunk>
Chunk BuildChunk(const std::vector<int32_t>& features, const std::vector<int>& runs) {
  Chunk chunk;
  chunk.features = features;
  for (size_t k = 0; k < features.size(); ++k) {
    chunk.feature_begin.push_back(static_cast<int64_t>(chunk.observations.size()));
    for (int r = 0; r < runs[k]; ++r) {
      typename Chunk::ObservationType o;
      o.feature = features[k];
      o.pose = static_cast<int32_t>(chunk.observations.size());
      chunk.observations.push_back(o);
    }
  }
  chunk.feature_begin.push_back(static_cast<int64_t>(chunk.observations.size()));
  return chunk;
}

template <class Chunk>
void ExpectIndexRebuilt(const Chunk& built) {
  Chunk chunk;
  chunk.observations = built.observations;
  chunk.features = {99};  // stale: must be replaced
  chunk.feature_begin = {0, 7};
  IndexFeatureRuns(&chunk);
  EXPECT_EQ(chunk.features, built.features);
  EXPECT_EQ(chunk.feature_begin, built.feature_begin);
  IndexFeatureRuns(&chunk);  // idempotent
  EXPECT_EQ(chunk.features, built.features);
  EXPECT_EQ(chunk.feature_begin, built.feature_begin);
}

TEST(ChunkFeatureRunsTest, IndexFeatureRunsOfFixedRuns) {
  ExpectIndexRebuilt(BuildChunk<ObservationChunk>({2, 5, 7}, {2, 1, 3}));
  ExpectIndexRebuilt(BuildChunk<ObservationChunk>({0, 1, 2, 3}, {1, 1, 1, 1}));
  ExpectIndexRebuilt(BuildChunk<ObservationChunk>({42}, {5}));
  ExpectIndexRebuilt(BuildChunk<ObservationChunk3d>({3, 9}, {4, 2}));
}

TEST(ChunkFeatureRunsTest, IndexFeatureRunsOfNoObservationIsOneBoundary) {
  ObservationChunk chunk;
  IndexFeatureRuns(&chunk);
  EXPECT_TRUE(chunk.features.empty());
  EXPECT_EQ(chunk.feature_begin, std::vector<int64_t>{0});
}

TEST(ChunkFeatureRunsTest, IndexFeatureRunsOfRandomRuns) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> gap(1, 5), run(1, 6), count(1, 60);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<int32_t> features;
    std::vector<int> runs;
    int32_t f = -1;
    for (int k = count(rng); k > 0; --k) {
      f += gap(rng);
      features.push_back(f);
      runs.push_back(run(rng));
    }
    ExpectIndexRebuilt(BuildChunk<ObservationChunk>(features, runs));
  }
}

}  // namespace
}  // namespace graphslam::core
