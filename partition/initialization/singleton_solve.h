// SolveWithoutSingletons: SolveGraphSlam with every feature that has exactly
// one observation kept out of the Levenberg-Marquardt loop, and placed
// afterwards where that observation puts it.
//
// Why it is exact. A planar feature m (2 unknowns) seen by one observation
// e(x_p, m) (2 residuals) whose Jacobian E = de/dm is invertible (point
// observations always; range-bearing at range > 0) can always fit it:
//   min_m rho(e^T W e) = 0   at   m*(x_p) = h^{-1}(x_p, z)   (Table 1),
// for every pose x_p. So the cost of the poses, min over the features, does
// not depend on the singleton at all, and neither does the reduced system:
// its Schur complement is
//   A^T W A - A^T W E (E^T W E)^{-1} E^T W A = A^T W A - A^T W A = 0
// (A = de/dx_p, E square and invertible). Leaving it out changes neither the
// optimum of the poses nor the chi2 there.
//
// Why it matters. Kept in, the singleton is recovered after each step by the
// linear update of Table 4, dm = -C^{-1}(g + H dx), which misses the exact
// m*(x_p + dx) by about r |dtheta|^2 / 2 (r: range, dtheta: the heading change
// of its pose). Each of these errors is seen through the observation's
// information (sigma 0.1 m / 0.02 rad on the campus), so on problems with many
// singletons the candidate chi2 of a good pose step is dominated by them and
// the step is rejected: the id-less campus of the association benchmark (all
// 73 123 features singletons before the first merges) had Gauss-Newton steps
// with rho = -2.5 .. -59 and stopped at the 100-iteration limit far from the
// optimum (docs/association.md, docs/benchmarks.md).
//
// THREAD SAFETY: one call at a time per problem (like SolveGraphSlam).
// ALLOCATION: a copy of the problem's observations without the singletons,
// cut into in-memory chunks (partition/ingest/in_memory_chunk_source.h).
#pragma once

#include <cstdint>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "partition/ingest/in_memory_chunk_source.h"

namespace graphslam::partition {

// Solves *problem like SolveGraphSlam over InMemoryChunkSource(*problem,
// chunking), except that features with exactly one observation are kept out of
// the solve and then placed at h^{-1}(x_p, z) from the solved pose; their chi2
// is then 0, so summary->final_chi2 is the chi2 of the whole problem.
// *singletons (optional) receives how many features were placed that way.
// With release_observations (a caller that needs them no more, e.g. a
// stage's sub-problem) problem->observations are taken over by the chunk
// source, which reorders them in place into chunks: they are held once, not
// once as the problem's and once as the chunks' while those are cut.
Status SolveWithoutSingletons(const core::SolverOptions& options, const ChunkingOptions& chunking,
                              core::Problem2d* problem, core::SolverSummary* summary,
                              int64_t* singletons = nullptr, bool release_observations = false);

}  // namespace graphslam::partition
