#include "partition/ingest/in_memory_chunk_source.h"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <utility>
#include <vector>

#include "tests/testing/random_problem.h"

namespace graphslam::partition {
namespace {

TEST(InMemoryChunkSource, ChunksAreFeatureCompleteSortedAndWithinBudget) {
  testing::RandomProblemOptions options;
  options.num_poses = 80;
  options.num_features = 40;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  const core::Problem2d& problem = random.problem;
  std::map<int32_t, int64_t> expected;
  for (const core::Observation& o : problem.observations) ++expected[o.feature];

  for (int64_t budget : {1, 10, 50, 100000}) {
    ChunkingOptions chunking;
    chunking.max_observations_per_chunk = budget;
    InMemoryChunkSource source(problem, chunking);
    std::set<int32_t> seen;
    int64_t total = 0;
    for (int64_t c = 0; c < source.NumChunks(); ++c) {
      core::ObservationChunk chunk;
      ASSERT_TRUE(source.Load(c, &chunk).ok());
      EXPECT_EQ(chunk.index, c);
      ASSERT_EQ(chunk.feature_begin.size(), chunk.features.size() + 1);
      EXPECT_TRUE(std::is_sorted(chunk.features.begin(), chunk.features.end()));
      const int64_t size = static_cast<int64_t>(chunk.observations.size());
      // Over budget only when a single feature alone exceeds it.
      if (chunk.features.size() > 1) {
        EXPECT_LE(size, budget);
      }
      for (size_t k = 0; k < chunk.features.size(); ++k) {
        const int32_t f = chunk.features[k];
        EXPECT_TRUE(seen.insert(f).second) << "feature " << f << " in two chunks";
        EXPECT_EQ(chunk.feature_begin[k + 1] - chunk.feature_begin[k], expected[f]);
        for (int64_t o = chunk.feature_begin[k]; o < chunk.feature_begin[k + 1]; ++o)
          EXPECT_EQ(chunk.observations[o].feature, f);
      }
      total += size;
    }
    EXPECT_EQ(total, static_cast<int64_t>(problem.observations.size()));
    EXPECT_EQ(seen.size(), expected.size());
  }
}

TEST(InMemoryChunkSource, ChunksFollowFirstSightForLocality) {
  testing::RandomProblemOptions options;
  options.num_poses = 120;
  options.num_features = 60;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  ChunkingOptions chunking;
  chunking.max_observations_per_chunk = 40;
  InMemoryChunkSource source(random.problem, chunking);
  ASSERT_GT(source.NumChunks(), 2);
  // The first pose seen in each chunk does not decrease from chunk to chunk.
  int32_t previous = -1;
  for (int64_t c = 0; c < source.NumChunks(); ++c) {
    core::ObservationChunk chunk;
    ASSERT_TRUE(source.Load(c, &chunk).ok());
    int32_t first = INT32_MAX;
    for (const core::Observation& o : chunk.observations) first = std::min(first, o.pose);
    EXPECT_GE(first, previous);
    previous = first;
  }
}

// Excluded features are left out exactly as if their observations had been
// filtered out first (the same chunks, observation for observation).
TEST(InMemoryChunkSource, ExcludedFeaturesMatchAFilteredCopy) {
  testing::RandomProblemOptions options;
  options.num_poses = 80;
  options.num_features = 40;
  const core::Problem2d problem = testing::MakeRandomProblem(options).problem;
  std::vector<uint8_t> excluded(problem.features.size(), 0);
  for (size_t f = 0; f < excluded.size(); f += 3) excluded[f] = 1;
  std::vector<core::Observation> filtered;
  for (const core::Observation& o : problem.observations)
    if (!excluded[o.feature]) filtered.push_back(o);
  ASSERT_LT(filtered.size(), problem.observations.size());
  ChunkingOptions chunking;
  chunking.max_observations_per_chunk = 30;
  const InMemoryChunkSource direct(problem.observations, problem.num_features(), chunking,
                                   excluded);
  const InMemoryChunkSource copied(filtered, problem.num_features(), chunking);
  ASSERT_EQ(direct.NumChunks(), copied.NumChunks());
  EXPECT_EQ(direct.observations_per_feature(), copied.observations_per_feature());
  for (int64_t c = 0; c < direct.NumChunks(); ++c) {
    core::ObservationChunk a, b;
    ASSERT_TRUE(direct.Load(c, &a).ok());
    ASSERT_TRUE(copied.Load(c, &b).ok());
    EXPECT_EQ(a.features, b.features);
    EXPECT_EQ(a.feature_begin, b.feature_begin);
    ASSERT_EQ(a.observations.size(), b.observations.size());
    for (size_t i = 0; i < a.observations.size(); ++i) {
      EXPECT_EQ(a.observations[i].feature, b.observations[i].feature);
      EXPECT_EQ(a.observations[i].pose, b.observations[i].pose);
      EXPECT_EQ(a.observations[i].z, b.observations[i].z);
    }
    for (int32_t f : a.features) EXPECT_EQ(excluded[f], 0);
  }
}

// The observations taken over (reordered in place) give the chunks of the
// copying constructor, and each feature's run in a chunk is its input
// observations in input order (lines number them), with or without
// excluded features.
TEST(InMemoryChunkSource, TakenOverObservationsKeepInputOrderPerFeature) {
  testing::RandomProblemOptions options;
  options.num_poses = 90;
  options.num_features = 50;
  core::Problem2d problem = testing::MakeRandomProblem(options).problem;
  for (size_t k = 0; k < problem.observations.size(); ++k)
    problem.observations[k].line = static_cast<int32_t>(k) + 1;
  std::vector<uint8_t> none, some(problem.features.size(), 0);
  for (size_t f = 1; f < some.size(); f += 4) some[f] = 1;
  for (const std::vector<uint8_t>& excluded : {none, some}) {
    std::map<int32_t, std::vector<int32_t>> lines;  // feature -> input lines
    for (const core::Observation& o : problem.observations)
      if (excluded.empty() || !excluded[o.feature]) lines[o.feature].push_back(o.line);
    ChunkingOptions chunking;
    chunking.max_observations_per_chunk = 25;
    const InMemoryChunkSource copied(problem.observations, problem.num_features(), chunking,
                                     excluded);
    std::vector<core::Observation> taken = problem.observations;
    const InMemoryChunkSource moved(std::move(taken), problem.num_features(), chunking,
                                    excluded);
    ASSERT_EQ(moved.NumChunks(), copied.NumChunks());
    EXPECT_EQ(moved.observations_per_feature(), copied.observations_per_feature());
    size_t features = 0;
    for (int64_t c = 0; c < moved.NumChunks(); ++c) {
      core::ObservationChunk a, b;
      ASSERT_TRUE(moved.Load(c, &a).ok());
      ASSERT_TRUE(copied.Load(c, &b).ok());
      EXPECT_EQ(a.index, c);
      EXPECT_EQ(a.features, b.features);
      EXPECT_EQ(a.feature_begin, b.feature_begin);
      ASSERT_EQ(a.observations.size(), b.observations.size());
      for (size_t k = 0; k < a.features.size(); ++k) {
        std::vector<int32_t> run;
        for (int64_t i = a.feature_begin[k]; i < a.feature_begin[k + 1]; ++i) {
          EXPECT_EQ(a.observations[i].feature, a.features[k]);
          EXPECT_EQ(a.observations[i].line, b.observations[i].line);
          EXPECT_EQ(a.observations[i].z, b.observations[i].z);
          const core::Observation& input = problem.observations[a.observations[i].line - 1];
          EXPECT_EQ(a.observations[i].pose, input.pose);
          EXPECT_EQ(a.observations[i].z, input.z);
          run.push_back(a.observations[i].line);
        }
        EXPECT_EQ(run, lines[a.features[k]]) << "feature " << a.features[k];
        ++features;
      }
    }
    EXPECT_EQ(features, lines.size());
  }
}

TEST(InMemoryChunkSource, LoadOutOfRangeIsAnError) {
  core::Problem2d problem;
  InMemoryChunkSource source(problem, ChunkingOptions());
  core::ObservationChunk chunk;
  EXPECT_TRUE(source.Load(0, &chunk).IsInvalidArgument());
}

}  // namespace
}  // namespace graphslam::partition
