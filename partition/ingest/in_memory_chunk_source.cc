#include "partition/ingest/in_memory_chunk_source.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <string>
#include <utility>

namespace graphslam::partition {

template <class ObservationT>
BasicInMemoryChunkSource<ObservationT>::BasicInMemoryChunkSource(
    const std::vector<ObservationT>& observations, int32_t num_features,
    const ChunkingOptions& options, std::span<const uint8_t> excluded)
    : BasicInMemoryChunkSource(
          [&] {
            GS_CHECK(excluded.empty() || excluded.size() == static_cast<size_t>(num_features));
            std::vector<ObservationT> kept;
            for (const ObservationT& o : observations) {
              GS_CHECK(o.feature >= 0 && o.feature < num_features);
              if (excluded.empty() || excluded[o.feature] == 0) kept.push_back(o);
            }
            return kept;
          }(),
          num_features, options) {}

template <class ObservationT>
BasicInMemoryChunkSource<ObservationT>::BasicInMemoryChunkSource(
    std::vector<ObservationT>&& observations, int32_t num_features,
    const ChunkingOptions& options, std::span<const uint8_t> excluded)
    : observations_(std::move(observations)) {
  GS_CHECK(excluded.empty() || excluded.size() == static_cast<size_t>(num_features));
  if (!excluded.empty()) {
    // Stable and in place: each feature's observations keep their order.
    std::erase_if(observations_, [&](const ObservationT& o) {
      GS_CHECK(o.feature >= 0 && o.feature < num_features);
      return excluded[o.feature] != 0;
    });
  }
  per_feature_.assign(num_features, 0);
  std::vector<int32_t> first_pose(num_features, std::numeric_limits<int32_t>::max());
  for (const ObservationT& observation : observations_) {
    GS_CHECK(observation.feature >= 0 && observation.feature < num_features);
    ++per_feature_[observation.feature];
    first_pose[observation.feature] = std::min(first_pose[observation.feature], observation.pose);
  }

  // Temporal locality: order observed features by the first pose that sees them.
  std::vector<int32_t> order;
  for (int32_t f = 0; f < num_features; ++f)
    if (per_feature_[f] > 0) order.push_back(f);
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return first_pose[a] < first_pose[b]; });
  std::vector<int32_t>().swap(first_pose);

  // The chunks, and where each feature's run starts in chunk order (chunk
  // after chunk, features ascending within one).
  std::vector<int64_t> next(num_features, 0);
  const int64_t budget = std::max<int64_t>(1, options.max_observations_per_chunk);
  std::vector<int32_t> members;
  int64_t members_observations = 0;
  int64_t placed = 0;
  auto flush = [&]() {
    if (members.empty()) return;
    std::sort(members.begin(), members.end());
    Chunk chunk;
    chunk.index = static_cast<int64_t>(chunks_.size());
    chunk.features = members;
    chunk.feature_begin.reserve(members.size() + 1);
    int64_t size = 0;
    for (int32_t f : members) {
      chunk.feature_begin.push_back(size);
      next[f] = placed + size;
      size += per_feature_[f];
    }
    chunk.feature_begin.push_back(size);
    chunks_.push_back(std::move(chunk));
    chunk_begin_.push_back(placed);
    placed += size;
    members.clear();
    members_observations = 0;
  };
  for (int32_t f : order) {
    if (members_observations > 0 && members_observations + per_feature_[f] > budget) flush();
    members.push_back(f);
    members_observations += per_feature_[f];
  }
  flush();
  chunk_begin_.push_back(placed);

  // Each observation to its place in chunk order, input order kept within a
  // feature; the permutation is applied in place, cycle by cycle, so the
  // observations are never held twice.
  const auto n = static_cast<int64_t>(observations_.size());
  std::vector<int64_t> destination(static_cast<size_t>(n));
  for (int64_t i = 0; i < n; ++i) destination[i] = next[observations_[i].feature]++;
  std::vector<int64_t>().swap(next);
  for (int64_t i = 0; i < n; ++i) {
    while (destination[i] != i) {
      const int64_t d = destination[i];
      std::swap(observations_[i], observations_[d]);
      std::swap(destination[i], destination[d]);
    }
  }
}

template <class ObservationT>
Status BasicInMemoryChunkSource<ObservationT>::Load(int64_t index, Chunk* chunk) const {
  if (index < 0 || index >= NumChunks()) {
    return Status::InvalidArgument("chunk " + std::to_string(index) + " out of range; expected 0.." +
                                   std::to_string(NumChunks() - 1));
  }
  const Chunk& cut = chunks_[index];
  chunk->index = cut.index;
  chunk->features = cut.features;
  chunk->feature_begin = cut.feature_begin;
  chunk->observations.assign(observations_.begin() + chunk_begin_[index],
                             observations_.begin() + chunk_begin_[index + 1]);
  return Status::Ok();
}

template class BasicInMemoryChunkSource<core::Observation>;
template class BasicInMemoryChunkSource<core::Point3Observation>;

}  // namespace graphslam::partition
