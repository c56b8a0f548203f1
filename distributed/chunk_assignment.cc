#include "distributed/chunk_assignment.h"

#include <algorithm>

namespace graphslam::distributed {

std::vector<int> AssignChunks(const std::vector<int64_t>& observations, int ranks) {
  std::vector<int> owner(observations.size(), 0);
  int64_t total = 0;
  for (int64_t o : observations) total += o;
  if (total == 0 || ranks <= 1) return owner;
  int64_t before = 0;
  for (size_t k = 0; k < observations.size(); ++k) {
    // 2 N (P_k + o_k / 2) / (2 T) in integers: no rounding of the midpoint.
    const __int128 numerator = static_cast<__int128>(ranks) * (2 * before + observations[k]);
    const int64_t r = static_cast<int64_t>(numerator / (2 * static_cast<__int128>(total)));
    owner[k] = static_cast<int>(std::min<int64_t>(r, ranks - 1));
    before += observations[k];
  }
  return owner;
}

std::vector<int> SplitRows(int block_rows, int ranks) {
  std::vector<int> first(static_cast<size_t>(ranks) + 1);
  for (int r = 0; r <= ranks; ++r)
    first[r] = static_cast<int>(static_cast<int64_t>(r) * block_rows / ranks);
  return first;
}

int RowOwner(const std::vector<int>& first, int row) {
  return static_cast<int>(std::upper_bound(first.begin(), first.end(), row) - first.begin()) - 1;
}

Status SubsetChunkSource::Load(int64_t index, core::ObservationChunk* chunk) const {
  return source_->Load(owned_[static_cast<size_t>(index)], chunk);
}

}  // namespace graphslam::distributed
