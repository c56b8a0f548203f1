// Which chunks each MPI rank owns, and the pose rows of the reduced system
// each rank owns (docs/distributed.md).
//
//   chunks: contiguous ranges of the manifest's chunk order with balanced
//           observation counts. With prefix sums P_k (observations of chunks
//           0..k-1, P_K = T), chunk k goes to rank
//               r(k) = min(N - 1, floor(N (P_k + o_k / 2) / T)),
//           the rank whose share [r T / N, (r + 1) T / N) holds the chunk's
//           midpoint. Chunks are ordered by the lowest pose observing their
//           features (the ingest's plan), so a contiguous range touches a
//           band of the trajectory. A rank may own no chunk (N > chunks).
//   rows:   contiguous ranges of the reduced system's block rows (poses in
//           trajectory order, then kept features): rank r owns
//               [floor(r B / N), floor((r + 1) B / N)).
//
// Pure functions of the inputs: every rank computes the same assignment.
#pragma once

#include <cstdint>
#include <vector>

#include "core/chunk_source.h"
#include "core/status.h"

namespace graphslam::distributed {

// The owner rank of every chunk; observations[k] are chunk k's (>= 0).
std::vector<int> AssignChunks(const std::vector<int64_t>& observations, int ranks);

// first[r] .. first[r + 1] - 1 are the block rows of rank r (size ranks + 1).
std::vector<int> SplitRows(int block_rows, int ranks);

// The rank owning block row `row` under `first` (SplitRows).
int RowOwner(const std::vector<int>& first, int row);

// A view of `source` with only the chunks of `owned` (ascending indices),
// renumbered 0..owned.size() - 1 for the passes; a loaded chunk keeps the
// index `source` gives it (its position in the whole store), so errors name
// the store's chunk.
class SubsetChunkSource : public core::ChunkSource {
 public:
  SubsetChunkSource(const core::ChunkSource* source, std::vector<int64_t> owned)
      : source_(source), owned_(std::move(owned)) {}
  int64_t NumChunks() const override { return static_cast<int64_t>(owned_.size()); }
  Status Load(int64_t index, core::ObservationChunk* chunk) const override;

 private:
  const core::ChunkSource* source_;
  std::vector<int64_t> owned_;
};

}  // namespace graphslam::distributed
