// InitializeFromPoseGraph: the streaming initializer for problems too large
// for progressive initialization (progressive_initialization.h, whose stages
// are in-memory sub-problems, O(poses^2 / 500)).
//
//   1. Solve the pose-only problem -- odometry, motion, GPS, fixed poses, no
//      observations -- with at most `max_iterations` Levenberg-Marquardt
//      iterations (SolveGraphSlam over an empty ChunkSource). Starting from
//      Table 1's dead reckoning this pulls the trajectory onto the GPS fixes
//      (without GPS or loop edges it is the dead reckoning already).
//   2. One streaming pass over the chunks re-places every feature from its
//      first observation (chunks keep each feature's observations in input
//      order) with the new poses: m = h^{-1}(x_p, z), as Table 1 does.
//      Chunks are feature-complete, so they are loaded and placed in
//      parallel (TBB); the result does not depend on the thread count.
//
// Memory: the pose system of step 1, one chunk per thread in step 2 and a
// byte per feature.
// THREAD SAFETY: one call per problem (it runs TBB tasks itself).
#pragma once

#include "core/chunk_source.h"
#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"

namespace graphslam::partition {

struct PoseGraphInitializationSummary {
  int iterations = 0;
  double initial_chi2 = 0;  // pose-only chi2 before / after step 1
  double final_chi2 = 0;
  int64_t placed_features = 0;
};

// `solver` gives the linear solver etc.; its max_iterations is replaced by
// `max_iterations`, its checkpoint / resume / progress hooks are not used.
[[nodiscard]] Status InitializeFromPoseGraph(const core::SolverOptions& solver, int max_iterations,
                                             const core::ChunkSource& chunks,
                                             core::Problem2d* problem,
                                             PoseGraphInitializationSummary* summary);

// Step 2 alone: every feature with an observation in `chunks` placed from its
// first observation with problem->poses; *placed_features counts them.
[[nodiscard]] Status PlaceFeaturesFromFirstSight(int max_chunks_in_flight,
                                                 const core::ChunkSource& chunks,
                                                 core::Problem2d* problem,
                                                 int64_t* placed_features);

}  // namespace graphslam::partition
