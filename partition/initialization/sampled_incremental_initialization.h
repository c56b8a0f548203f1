// InitializeFromSampledFeatures: the start of a streaming solve (observations
// stay on disk in feature-complete chunks) in the basin of the optimum, by
// incremental initialization (incremental_initialization.h, the in-memory
// default) of the problem restricted to a sample of its features.
//
//   1. Budget: B = max(min_observations, observations_per_pose * poses)
//      observations, at most max_observations (a memory limit's share);
//      sampling rate r = min(1, B / M) for M observations.
//   2. One streaming pass over the chunks keeps every feature f with
//      u(f) < r, u(f) in [0, 1) a fixed hash of its index (SplitMix64), with
//      all its observations (chunks are feature-complete). A pose that sees
//      n features keeps about r n of them, spread over its field of view, so
//      dense sensing (hundreds of features per pose) still gives every pose
//      tens of features: enough to localize it (feature_localization.h) and
//      to tie it to its neighbours as the whole set does. With r = 1 (M <= B)
//      the sub-problem is the whole problem.
//   3. The sub-problem -- every pose and pose constraint (odometry, motion,
//      GPS, robot sightings), the sampled features and their observations --
//      gets incremental initialization, then Levenberg-Marquardt in memory
//      (at most sub_solve_iterations): its poses end at the sample's optimum,
//      which differs from the whole problem's by the information the other
//      features add, well inside its basin. A stretch that solve folded over
//      is then repaired as after the last stage (incremental_initialization.h:
//      RepairBrokenOdometry).
//   4. The poses are copied back; one more streaming pass places every
//      feature from its first observation with them (Table 1 inverted,
//      pose_graph_initialization.h PlaceFeaturesFromFirstSight), and the
//      sampled ones then take their solved positions.
//
// Why not the pose-graph start (pose_graph_initialization.h) for streaming:
// with weak odometry (0.03 rad per pose) and GPS every 50 poses the poses
// between fixes drift, the features placed from them carry that drift, and
// Levenberg-Marquardt from there stalls in a local minimum (a few poses turned
// by ~pi: chi2/dof 1.088 on a 10^6-feature campus) or crawls (1.57 after 30
// iterations at 10^7). Features localize a pose far better than such
// odometry; the sample keeps that at a memory cost bounded by B.
//
// Memory: O(poses + B) for the sub-problem and its solves (B proportional to
// the poses; the sample held as 32-byte records, compact_observations.h), one
// chunk per pass in flight, and a byte per feature for the placement pass;
// never the whole problem's observations. The whole problem's feature
// estimates (16 B each) are freed from the end of the sampling pass to step
// 4, which places every observed feature anew: only the guesses of features
// no chunk observes are kept (a bit per feature finds them). The caller may
// have parked the feature ids (problem->feature_ids empty): the sub-problem
// then names each sampled feature by its index.
// THREAD SAFETY: one call per problem (it runs TBB tasks itself); the result
// does not depend on the thread count (chunks merged in order).
#pragma once

#include <cstdint>

#include "core/chunk_source.h"
#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "partition/initialization/incremental_initialization.h"

namespace graphslam::partition {

struct SampledInitializationOptions {
  // The sample's observation budget B (above): per pose, and at least.
  int64_t observations_per_pose = 24;
  int64_t min_observations = 1'000'000;
  // > 0: B itself, in place of the rule above (--sample-observations).
  int64_t budget_observations = 0;
  // And at most this many (a memory limit's share; -1: no cap).
  int64_t max_observations = -1;
  // Levenberg-Marquardt iterations on the sampled sub-problem after its
  // incremental initialization (0: none).
  int sub_solve_iterations = 30;
  // Its relative chi2 decrease to stop at (the whole solve's default is
  // 1e-6). Looser: the whole problem's solve, which adds every other
  // feature, moves the poses further than the sample's last iterations do.
  double sub_solve_function_tolerance = 1e-4;
  // The stages' options: the in-memory defaults, but
  //  - windows in proportion to their new poses (window_observations_per_new
  //    2, what max_window_observations = 2 max_new_observations gives a
  //    full-size stage already): with the sample's sparse sensing (~24
  //    observations per pose) over a quarter of the stage attempts are
  //    redone with fewer new poses, and a redo's window then shrinks too;
  //  - full stages stopping at sub_solve_function_tolerance's 1e-4: the
  //    sample's solve follows them and makes their last decreases anyway.
  IncrementalInitializationOptions incremental = SampledStageOptions();

  static IncrementalInitializationOptions SampledStageOptions() {
    IncrementalInitializationOptions stages;
    stages.window_observations_per_new = 2.0;
    stages.full_stage_function_tolerance = 1e-4;
    return stages;
  }
};

struct SampledInitializationSummary {
  int64_t budget_observations = 0;  // B above, after the cap
  bool capped = false;              // B lowered to max_observations
  double rate = 1.0;  // r above
  int64_t sampled_features = 0;
  int64_t sampled_observations = 0;
  IncrementalSummary incremental;
  int sub_solve_iterations = 0;
  double sub_solve_initial_chi2 = 0.0;
  double sub_solve_final_chi2 = 0.0;
  int64_t placed_features = 0;
  double seconds = 0.0;
};

// The feature's hash u(f) in [0, 1) of step 2.
double FeatureSampleKey(int32_t feature);

// B of step 1 for a problem of `poses` poses, before the max_observations
// cap: budget_observations if set, else max(min_observations,
// observations_per_pose * poses).
int64_t SampleBudget(const SampledInitializationOptions& options, int64_t poses);

// Replaces problem->poses and problem->features (through Table 1 already:
// the ingest's guess) by the start described above. `problem` holds no
// observations (they are `chunks`, `total_observations` of them). `solver`
// gives the linear solver etc.; its callbacks, checkpoint and candidate store
// are not used.
[[nodiscard]] Status InitializeFromSampledFeatures(const SampledInitializationOptions& options,
                                                   const core::SolverOptions& solver,
                                                   const core::ChunkSource& chunks,
                                                   int64_t total_observations,
                                                   core::Problem2d* problem,
                                                   SampledInitializationSummary* summary);

}  // namespace graphslam::partition
