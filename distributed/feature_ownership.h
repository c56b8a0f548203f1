// FeatureOwnership: the features one MPI rank holds, numbered locally, so
// that its per-feature arrays (estimates, excluded / kept flags, candidates,
// the layout's feature index) have one entry per feature of its own chunks
// instead of one per feature of the store (docs/distributed.md, "Features
// on ranks").
//
// Every feature is in exactly one chunk (chunks are feature-complete), so in
// exactly one rank's chunks. A rank's local array is
//
//   [0, K)        shared: every feature with more than
//                 max_eliminated_observations observations (the only ones
//                 ScreenFeatures can make "kept" unknowns of the reduced
//                 system), in ascending global index, the same K on every
//                 rank. Kept features are numbered after the poses in
//                 feature order (UnknownLayout::KeepFeatures), and the
//                 reduced system is one system across ranks, so their order
//                 must be the global one: a rank that does not own a shared
//                 feature sees it as unobserved, and the screening's AND /
//                 OR over ranks (MpiRanks::SumScreening, first K entries)
//                 gives every rank the owner's flags.
//   [K, K + F_r)  region: the other features of the rank's chunks, in chunk
//                 order, then in each chunk's order.
//
// OwnedFeatureChunkSource serves the rank's chunks with chunk.features
// renumbered to local indices (a chunk's positions and observations are
// unchanged, so every pass computes what it computes on global indices).
// Memory: 4 bytes per region feature and per shared feature, 8 per chunk.
//
// THREAD SAFETY: Build is collective; the source's Load may run concurrently
// for distinct chunks. ALLOCATION: as above, plus one chunk while building.
#pragma once

#include <mpi.h>

#include <cstdint>
#include <vector>

#include "core/chunk_source.h"
#include "core/status.h"

namespace graphslam::distributed {

struct FeatureOwnership {
  std::vector<int32_t> shared;               // global index of local 0..K-1, ascending
  std::vector<int32_t> region;               // global index of local K + i
  std::vector<int64_t> chunk_region_begin;   // per own chunk: its first region slot
  // The local indices this rank owns (its chunks' features: some shared,
  // then the whole region) and their global indices, ascending local.
  std::vector<int32_t> owned_local;
  std::vector<int32_t> owned_global;
  int64_t observed_features = 0;             // features in any chunk, all ranks
  int64_t max_eliminated_observations = 0;

  int64_t num_local() const {
    return static_cast<int64_t>(shared.size() + region.size());
  }
};

// Collective: loads each of `chunks` (the rank's own, in order) once.
Status BuildFeatureOwnership(MPI_Comm comm, const core::ChunkSource& chunks,
                             int64_t max_eliminated_observations, FeatureOwnership* ownership);

// The rank's chunks with local feature indices (see above).
class OwnedFeatureChunkSource : public core::ChunkSource {
 public:
  OwnedFeatureChunkSource(const core::ChunkSource* chunks, const FeatureOwnership* ownership)
      : chunks_(chunks), ownership_(ownership) {}
  int64_t NumChunks() const override { return chunks_->NumChunks(); }
  // Corruption if the chunk's features are not those it had when the
  // ownership was built.
  Status Load(int64_t index, core::ObservationChunk* chunk) const override;

 private:
  const core::ChunkSource* chunks_;
  const FeatureOwnership* ownership_;
};

}  // namespace graphslam::distributed
