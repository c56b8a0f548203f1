// The solver checkpoint across MPI ranks (docs/distributed.md, "Checkpoints
// and --resume"). What a distributed solve carries from one iteration to the
// next is, per rank:
//
//   replicated  poses, excluded / kept flags, the Levenberg-Marquardt scalars
//               (radius, decrease factor, chi2s, iteration): every rank holds
//               the same bits, because everything the control reads is summed
//               over the ranks before it reads it (distributed/mpi_ranks.h);
//   owned       the estimates of the features of the rank's own chunks (every
//               feature is in exactly one chunk, so in one rank's set);
//   none        the KSP keeps no state between solves (zero initial guess).
//
// So the whole state is the replicated part plus the disjoint union of the
// owned parts. GatherFeaturesToRoot assembles the union on rank 0 (a sum of
// values that are zero outside the owner: exact), which writes the ordinary
// one-process checkpoint atomically (storage/solver_checkpoint.h); a resume
// reads it on rank 0 and BroadcastCheckpoint gives every rank the replicated
// part (each takes its features from the broadcast start).
//
// THREAD SAFETY: collective; every rank calls in the same order.
// ALLOCATION: the broadcast arrays; GatherFeaturesToRoot one feature array.
#pragma once

#include <mpi.h>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/graphslam_solver.h"

namespace graphslam::distributed {

// MPI_Bcast of `bytes` bytes from rank 0, in pieces of at most 1 GiB (MPI
// counts are int). The receivers wait without spinning on a core
// (MPI_Ibcast, then MPI_Test every millisecond): rank 0 may be busy for long
// (initialization, reading a checkpoint).
void BroadcastBytes(MPI_Comm comm, void* data, size_t bytes);

// Whether rank 0 has a checkpoint to resume from (`root` non-null there),
// and if so, its replicated part into *local on every other rank: the
// scalars, poses, excluded, kept; not the features (they travel with the
// start) nor the PCG state (the KSP has none). Returns the flag.
bool BroadcastCheckpoint(MPI_Comm comm, const core::SolverCheckpoint* root,
                         core::SolverCheckpoint* local);

// On rank 0: *gathered[g] = features[g] of the rank whose `owned[g]` is 1,
// zero for a feature no rank owns. Other ranks: *gathered is left empty.
void GatherFeaturesToRoot(MPI_Comm comm, const std::vector<uint8_t>& owned,
                          const std::vector<core::Point2>& features,
                          std::vector<core::Point2>* gathered);

}  // namespace graphslam::distributed
