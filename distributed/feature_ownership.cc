#include "distributed/feature_ownership.h"

#include <algorithm>
#include <string>

namespace graphslam::distributed {
namespace {

Status ChangedChunk(const core::ObservationChunk& chunk, int64_t position) {
  return Status::Corruption("chunk " + std::to_string(chunk.index) + ": feature " +
                            std::to_string(chunk.features[static_cast<size_t>(position)]) +
                            " at position " + std::to_string(position) +
                            " is not the one this rank numbered there when the solve started");
}

}  // namespace

Status BuildFeatureOwnership(MPI_Comm comm, const core::ChunkSource& chunks,
                             int64_t max_eliminated_observations, FeatureOwnership* ownership) {
  *ownership = FeatureOwnership();
  ownership->max_eliminated_observations = max_eliminated_observations;
  std::vector<int32_t> mine_shared;
  core::ObservationChunk chunk;
  Status loaded = Status::Ok();
  for (int64_t c = 0; c < chunks.NumChunks() && loaded.ok(); ++c) {
    loaded = chunks.Load(c, &chunk);
    ownership->chunk_region_begin.push_back(static_cast<int64_t>(ownership->region.size()));
    if (!loaded.ok()) break;
    for (int64_t k = 0; k < chunk.num_features(); ++k) {
      const int64_t count = chunk.feature_begin[k + 1] - chunk.feature_begin[k];
      (count > max_eliminated_observations ? mine_shared : ownership->region)
          .push_back(chunk.features[static_cast<size_t>(k)]);
    }
  }
  // The collectives run on every rank whatever its status (the caller agrees).
  int size = 1;
  MPI_Comm_size(comm, &size);
  int count = static_cast<int>(mine_shared.size());
  std::vector<int> counts(size), displacements(size, 0);
  MPI_Allgather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, comm);
  for (int r = 1; r < size; ++r) displacements[r] = displacements[r - 1] + counts[r - 1];
  ownership->shared.resize(static_cast<size_t>(displacements.back() + counts.back()));
  MPI_Allgatherv(mine_shared.data(), count, MPI_INT32_T, ownership->shared.data(), counts.data(),
                 displacements.data(), MPI_INT32_T, comm);
  std::sort(ownership->shared.begin(), ownership->shared.end());
  int64_t observed = static_cast<int64_t>(mine_shared.size() + ownership->region.size());
  MPI_Allreduce(MPI_IN_PLACE, &observed, 1, MPI_INT64_T, MPI_SUM, comm);
  ownership->observed_features = observed;
  GS_RETURN_IF_ERROR(loaded);
  if (std::adjacent_find(ownership->shared.begin(), ownership->shared.end()) !=
      ownership->shared.end())
    return Status::Corruption("a feature is in more than one chunk of the store");

  const std::vector<int32_t>& shared = ownership->shared;
  const int32_t k_shared = static_cast<int32_t>(shared.size());
  std::sort(mine_shared.begin(), mine_shared.end());
  for (int32_t g : mine_shared) {
    ownership->owned_local.push_back(
        static_cast<int32_t>(std::lower_bound(shared.begin(), shared.end(), g) - shared.begin()));
    ownership->owned_global.push_back(g);
  }
  for (size_t i = 0; i < ownership->region.size(); ++i) {
    ownership->owned_local.push_back(k_shared + static_cast<int32_t>(i));
    ownership->owned_global.push_back(ownership->region[i]);
  }
  return Status::Ok();
}

Status OwnedFeatureChunkSource::Load(int64_t index, core::ObservationChunk* chunk) const {
  GS_RETURN_IF_ERROR(chunks_->Load(index, chunk));
  const FeatureOwnership& own = *ownership_;
  const std::vector<int32_t>& shared = own.shared;
  const int32_t k_shared = static_cast<int32_t>(shared.size());
  const size_t next = static_cast<size_t>(index) + 1;
  int64_t slot = own.chunk_region_begin[static_cast<size_t>(index)];
  const int64_t end = next < own.chunk_region_begin.size()
                          ? own.chunk_region_begin[next]
                          : static_cast<int64_t>(own.region.size());
  for (int64_t k = 0; k < chunk->num_features(); ++k) {
    int32_t& g = chunk->features[static_cast<size_t>(k)];
    const int64_t count = chunk->feature_begin[k + 1] - chunk->feature_begin[k];
    if (count > own.max_eliminated_observations) {
      const auto it = std::lower_bound(shared.begin(), shared.end(), g);
      if (it == shared.end() || *it != g) return ChangedChunk(*chunk, k);
      g = static_cast<int32_t>(it - shared.begin());
    } else {
      if (slot >= end || own.region[static_cast<size_t>(slot)] != g)
        return ChangedChunk(*chunk, k);
      g = k_shared + static_cast<int32_t>(slot++);
    }
  }
  if (slot != end)
    return Status::Corruption("chunk " + std::to_string(chunk->index) + ": " +
                              std::to_string(end - slot) +
                              " fewer features than when the solve started");
  return Status::Ok();
}

}  // namespace graphslam::distributed
