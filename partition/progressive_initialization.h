// InitializeProgressively: an initial guess in the basin of the global optimum,
// built the way incremental smoothers (iSAM, Kaess et al. 2008) build theirs:
// by optimizing growing prefixes of the trajectory in time order.
//
// Levenberg-Marquardt from a dead-reckoning guess can settle in a local
// minimum when the odometry drift is large compared with the landmark
// geometry (Victoria Park: chi2 13.1k..34k instead of 12058.87). A smoother
// that adds poses a few at a time never sees that drift: each new pose starts
// from its odometry chained off an already-optimized predecessor, and each new
// feature from its first sighting from that optimized pose, so every
// increment starts close to the optimum of its prefix.
//
// Stages. With N poses (index order = time order in every importer), the
// prefix lengths are
//   T_0 = min(first_poses, N),  T_{k+1} = min(N, max(T_k + 1, ceil(growth T_k)))
// up to T_K = N. Stage k optimizes the sub-problem P_k of
//   poses      x_0 .. x_{T_k - 1}
//   features   every m_j observed from some pose p < T_k (keeping its id)
//   edges      relative poses / motions with both ends < T_k, GPS of p < T_k,
//              observations from p < T_k
// for at most max_iterations_per_stage LM iterations (SolveGraphSlam with the
// caller's options otherwise, in-memory chunks). Before stage k, for k > 0:
//   new pose p in [T_{k-1}, T_k):  x_p = x_q (+) z           (relative pose q->p)
//                                  x_p = x_q (+) z^{-1}      (relative pose p->q)
//                                  x_p = g(u, x_q)           (motion q->p, Table 1)
//                                  x_p = g^{-1}(u, x_q)      (motion p->q)
//     with q the placed neighbour of highest index (the odometry predecessor);
//     a pose no such edge reaches keeps its input offset from the nearest
//     lower placed pose: x_p = x_q (+) (x_q^in (-) x_p^in).
//   new feature j (first observed from p in the new range, lowest pose index
//     first, then input order):  m_j = h^{-1}(x_p, z)
//     (range-bearing: t + r (cos(th + phi), sin(th + phi)); point: t + R(th) z).
// Stage 0 starts from the input guess. The gauge is the sub-problem's own
// (UnknownLayout): pose 0 or the fixed poses, which every prefix contains.
//
// Down-weighted landmark stage (optional, landmark_weight < 1): each stage
// first runs the same iterations with every observation information scaled by
// landmark_weight, so odometry dominates while the map is still wrong, then the
// true weights. A graduated scheme in the spirit of graduated non-convexity.
//
// The result is written to problem->poses / problem->features (features
// marked initialized); the caller then runs the full SolveGraphSlam as usual.
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

namespace graphslam::partition {

struct ProgressiveInitializationOptions {
  bool enabled = true;
  // Poses of the first stage (T_0).
  int64_t first_poses = 100;
  // Prefix growth factor between stages (> 1).
  double growth = 2.0;
  // LM iterations per stage (each sub-problem solve).
  int max_iterations_per_stage = 10;
  // Solve the last stage (all poses) too; when false the last stage only
  // places the remaining poses and features and leaves the solve to the caller.
  bool solve_last_stage = true;
  // In (0, 1]: < 1 runs each stage first with observation information scaled
  // by this factor (see above); 1 disables that pass.
  double landmark_weight = 1.0;
  // Chunking of each stage's observations.
  int64_t max_observations_per_chunk = 4096;

  Status Validate() const;
};

struct ProgressiveStageSummary {
  int64_t poses = 0;         // T_k
  int64_t features = 0;      // features in the sub-problem
  int64_t observations = 0;  // observations in the sub-problem
  double initial_chi2 = 0.0; // of the sub-problem, after placing the new unknowns
  double final_chi2 = 0.0;
  int iterations = 0;        // LM iterations of all passes of the stage
  std::string termination;   // of the last pass
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
