// InitializeProgressively: an initial guess in the basin of the global optimum,
// built the way incremental smoothers (iSAM, Kaess et al. 2008) build theirs:
// by optimizing growing prefixes of the trajectory in time order.
//
// Levenberg-Marquardt from a dead-reckoning guess can settle in a local
// minimum when the odometry drift is large compared with the landmark
// geometry (Victoria Park: chi2 13.1k..34k instead of 389.79). A smoother
// that adds poses a few at a time never sees that drift: each new pose starts
// from its odometry chained off an already-optimized predecessor, and each new
// feature from its first sighting from that optimized pose, so every
// increment starts close to the optimum of its prefix.
//
// Stages. With N poses (index order = time order in every importer), the
// prefix lengths are
//   T_0 = min(first_poses, N),
//   T_{k+1} = min(N, max(T_k + 1, min(ceil(growth T_k), T_k + A_k)))
// up to T_K = N, where A_0 = max_new_poses and A_{k+1} = max(min(min_new_poses,
// max_new_poses), A_k / 2) when stage k was unsettled (stopped by max_iterations_per_stage
// while its last iteration still lowered chi2 by more than 1 %: the chained
// segment was too far from the optimum for a few iterations), else
// min(max_new_poses, 2 A_k). Without that control a long run ends stage
// after stage unconverged, each chained off a worse end (docs/tuning.md).
// Stage k optimizes the sub-problem P_k of
//   poses      x_0 .. x_{T_k - 1}
//   features   every m_j observed from some pose p < T_k (keeping its id;
//              those seen once are left out of the solve and placed from
//              their observation, exactly: partition/initialization/singleton_solve.h)
//   edges      relative poses / motions with both ends < T_k, GPS of p < T_k,
//              observations from p < T_k
// for at most max_iterations_per_stage LM iterations (SolveGraphSlam with the
// caller's options otherwise, in-memory chunks). Before stage k, for k > 0:
//   new pose p in [T_{k-1}, T_k):  x_p = x_q (+) z           (relative pose q->p)
//                                  x_p = x_q (+) z^{-1}      (relative pose p->q)
//                                  x_p = g(u, x_q)           (motion q->p, Table 1)
//                                  x_p = g^{-1}(u, x_q)      (motion p->q)
//     with q the placed neighbour of highest index (the odometry predecessor);
//     the lowest pose no such edge reaches (the start of another odometry
//     chain, e.g. the first pose of a later run) keeps its input guess,
//     x_p = x_p^in, and the poses after it chain from it.
//   new feature j (first observed from p in the new range, lowest pose index
//     first, then input order):  m_j = h^{-1}(x_p, z)
//     (range-bearing: t + r (cos(th + phi), sin(th + phi)); point: t + R(th) z).
// Stage 0 starts from the input guess. The gauge is the sub-problem's own
// (UnknownLayout): pose 0 or the fixed poses, which every prefix contains.
//
// The last stage (T_K = N) only places its new poses and features unless
// solve_last_stage. The result is written to problem->poses /
// problem->features (features marked initialized); the caller then runs the
// full SolveGraphSlam as usual.
//
// Victoria Park (6969 poses, 151 features, 3640 observations): from the
// odometry guess LM stops at chi2 13.1k..34k; after this initialization
// (defaults) the full solve converges to chi2 389.787 (the g2o reference run
// from odometry, 12058.87, is a local minimum as well). The geometric growth
// keeps early stages cheap; the cap keeps the chained odometry segment short
// once the trajectory is long (uncapped growth 2 ended at 13.2k).
//
// THREAD SAFETY: one call at a time per problem; each stage solve is
// internally parallel (TBB) like SolveGraphSlam and results do not depend on
// the thread count. ALLOCATION: O(poses + features + constraints) for the
// working copies, plus one sub-problem and its chunks (at most a copy of the
// whole problem) per stage, released before the next.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "partition/initialization/prefix_stages.h"

namespace graphslam::partition {

// The schedule is PrefixStageOptions' (max_new_poses 0: no cap).
struct ProgressiveInitializationOptions : PrefixStageOptions {
  // Solve the last stage (all poses) too. By default the last stage only
  // places the remaining poses and features: the caller's full solve follows.
  bool solve_last_stage = false;

  Status Validate() const;
};

struct ProgressiveStageSummary {
  int64_t poses = 0;         // T_k
  int64_t features = 0;      // features in the sub-problem
  int64_t observations = 0;  // observations in the sub-problem
  double initial_chi2 = 0.0; // of the sub-problem, after placing the new unknowns
  double final_chi2 = 0.0;
  int iterations = 0;        // LM iterations of the stage solve
  std::string termination;   // of the stage solve
  double seconds = 0.0;
};

struct ProgressiveSummary {
  bool ran = false;  // false when options.enabled is false
  std::vector<ProgressiveStageSummary> stages;
  double seconds = 0.0;
};

// Replaces the initial guess of *problem (already through
// core::InitializeProblem) by the progressive one described above. `base`
// supplies the solver settings of every stage; its max_iterations is replaced
// by max_iterations_per_stage and its callbacks are not forwarded except
// `progress`, called once per stage with stage "progressive initialization"
// and done/total in poses. On error *problem is unchanged and *summary holds
// the stages done so far.
Status InitializeProgressively(const ProgressiveInitializationOptions& options,
                               const core::SolverOptions& base, core::Problem2d* problem,
                               ProgressiveSummary* summary);

}  // namespace graphslam::partition
