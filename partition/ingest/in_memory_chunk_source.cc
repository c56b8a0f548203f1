#include "partition/ingest/in_memory_chunk_source.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <string>

namespace graphslam::partition {

template <class ObservationT>
BasicInMemoryChunkSource<ObservationT>::BasicInMemoryChunkSource(
    const std::vector<ObservationT>& observations, int32_t num_features,
    const ChunkingOptions& options, std::span<const uint8_t> excluded) {
  GS_CHECK(excluded.empty() || excluded.size() == static_cast<size_t>(num_features));
  const auto kept = [&](int32_t f) { return excluded.empty() || excluded[f] == 0; };
  per_feature_.assign(num_features, 0);
  std::vector<int32_t> first_pose(num_features, std::numeric_limits<int32_t>::max());
  for (const ObservationT& observation : observations) {
    GS_CHECK(observation.feature >= 0 && observation.feature < num_features);
    if (!kept(observation.feature)) continue;
    ++per_feature_[observation.feature];
    first_pose[observation.feature] = std::min(first_pose[observation.feature], observation.pose);
  }
  // Observations grouped by feature, input order kept within a feature.
  std::vector<int64_t> feature_start(num_features + 1, 0);
  for (int32_t f = 0; f < num_features; ++f) feature_start[f + 1] = feature_start[f] + per_feature_[f];
  std::vector<int64_t> by_feature(static_cast<size_t>(feature_start[num_features]));
  std::vector<int64_t> cursor(feature_start.begin(), feature_start.end() - 1);
  for (int64_t i = 0; i < static_cast<int64_t>(observations.size()); ++i)
    if (kept(observations[i].feature)) by_feature[cursor[observations[i].feature]++] = i;

  // Temporal locality: order observed features by the first pose that sees them.
  std::vector<int32_t> order;
  for (int32_t f = 0; f < num_features; ++f)
    if (per_feature_[f] > 0) order.push_back(f);
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return first_pose[a] < first_pose[b]; });

  const int64_t budget = std::max<int64_t>(1, options.max_observations_per_chunk);
  std::vector<int32_t> members;
  int64_t members_observations = 0;
  auto flush = [&]() {
    if (members.empty()) return;
    std::sort(members.begin(), members.end());
    Chunk chunk;
    chunk.index = static_cast<int64_t>(chunks_.size());
    chunk.features = members;
    chunk.feature_begin.reserve(members.size() + 1);
    chunk.observations.reserve(members_observations);
    for (int32_t f : members) {
      chunk.feature_begin.push_back(static_cast<int64_t>(chunk.observations.size()));
      for (int64_t k = feature_start[f]; k < feature_start[f + 1]; ++k)
        chunk.observations.push_back(observations[by_feature[k]]);
    }
    chunk.feature_begin.push_back(static_cast<int64_t>(chunk.observations.size()));
    chunks_.push_back(std::move(chunk));
    members.clear();
    members_observations = 0;
  };
  for (int32_t f : order) {
    if (members_observations > 0 && members_observations + per_feature_[f] > budget) flush();
    members.push_back(f);
    members_observations += per_feature_[f];
  }
  flush();
}

template <class ObservationT>
Status BasicInMemoryChunkSource<ObservationT>::Load(int64_t index, Chunk* chunk) const {
  if (index < 0 || index >= NumChunks()) {
    return Status::InvalidArgument("chunk " + std::to_string(index) + " out of range; expected 0.." +
                                   std::to_string(NumChunks() - 1));
  }
  *chunk = chunks_[index];
  return Status::Ok();
}

template class BasicInMemoryChunkSource<core::Observation>;
template class BasicInMemoryChunkSource<core::Point3Observation>;

}  // namespace graphslam::partition
