// The solver checkpoint across MPI ranks (docs/distributed.md, "Checkpoints
// and --resume"). What a distributed solve carries from one iteration to the
// next is, per rank:
//
//   replicated  poses, the Levenberg-Marquardt scalars (radius, decrease
//               factor, chi2s, iteration) and the flags of the shared
//               features (distributed/feature_ownership.h): every rank holds
//               the same bits, because everything the control reads is
//               summed over the ranks before it reads it
//               (distributed/mpi_ranks.h);
//   owned       the estimates and excluded / kept flags of the features of
//               the rank's own chunks, in its local numbering (every feature
//               is in exactly one chunk, so in one rank's set);
//   none        the KSP keeps no state between solves (zero initial guess).
//
// So the whole state is the replicated part plus the disjoint union of the
// owned parts. FeatureExchange::Gather assembles the union on rank 0 (each
// rank sends its owned entries, rank 0 puts them at their global indices),
// which writes the ordinary one-process checkpoint atomically
// (storage/solver_checkpoint.h); a resume reads it on rank 0,
// BroadcastCheckpoint gives every rank the scalars and poses, and
// FeatureExchange::Scatter each rank its features' estimates and flags.
//
// THREAD SAFETY: collective; every rank calls in the same order.
// ALLOCATION: the broadcast arrays; on rank 0 every rank's global indices
// (4 bytes per observed feature) and one rank's values at a time.
#pragma once

#include <mpi.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/graphslam_solver.h"
#include "distributed/feature_ownership.h"

namespace graphslam::distributed {

// MPI_Bcast of `bytes` bytes from rank 0, in pieces of at most 1 GiB (MPI
// counts are int). The receivers wait without spinning on a core
// (MPI_Ibcast, then MPI_Test every millisecond): rank 0 may be busy for long
// (initialization, reading a checkpoint).
void BroadcastBytes(MPI_Comm comm, void* data, size_t bytes);

// Whether rank 0 has a checkpoint to resume from (`root` non-null there),
// and if so, its scalars and poses into *local on every rank (rank 0
// included); not the features or flags (FeatureExchange) nor the PCG state
// (the KSP has none). Returns the flag.
bool BroadcastCheckpoint(MPI_Comm comm, const core::SolverCheckpoint* root,
                         core::SolverCheckpoint* local);

// Moves per-feature values between rank 0's global arrays and every rank's
// local ones, over the entries each rank owns (FeatureOwnership::owned_local
// and owned_global). Point-to-point with rank 0, in rank order: no array
// of the store's size on any other rank, and no MPI count past one rank's
// own entries.
class FeatureExchange {
 public:
  // Collective: rank 0 learns every rank's owned_global.
  FeatureExchange(MPI_Comm comm, const FeatureOwnership* ownership);

  // Every rank: (*mine)[owned_local[i]] = root[owned_global[i]], with rank
  // 0's `root` (ignored on the others).
  template <class T>
  void Scatter(const std::vector<T>& root, std::vector<T>* mine) const {
    ScatterBytes(root.data(), mine->data(), sizeof(T));
  }
  // Rank 0: (*root)[g] = the owner's mine[l] for every rank's owned (l, g);
  // *root is rank 0's (the others' is not touched).
  template <class T>
  void Gather(const std::vector<T>& mine, std::vector<T>* root) const {
    GatherBytes(mine.data(), root->data(), sizeof(T));
  }
  int64_t owned() const { return static_cast<int64_t>(ownership_->owned_local.size()); }

 private:
  void ScatterBytes(const void* root, void* mine, size_t element) const;
  void GatherBytes(const void* mine, void* root, size_t element) const;

  MPI_Comm comm_;
  int rank_ = 0;
  int size_ = 1;
  const FeatureOwnership* ownership_;
  std::vector<std::vector<int32_t>> global_of_rank_;  // rank 0: ranks 1.. (0 is its own)
};

}  // namespace graphslam::distributed
