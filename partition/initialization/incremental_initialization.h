// InitializeIncrementally: an initial guess in the basin of the global optimum
// at a cost linear in the trajectory: progressive initialization
// (partition/initialization/progressive_initialization.h) with every stage re-solving a
// bounded window of recent poses instead of the whole prefix, in the manner
// of incremental smoothers (iSAM2, Kaess et al. 2012: a new measurement
// relinearizes only the variables it affects).
//
// Stages. Prefix lengths T_k grow as in progressive initialization
// (geometric from first_poses, at most A_k new poses, A_k halved after an
// unsettled stage and doubled back after a settled one), and the new poses
// of a stage hold at most max_new_observations observations (at least one
// pose): dense sensing (hundreds of observations per pose) makes a pose cost
// hundreds of times more than in a pose graph, so a stage is bounded by what
// it costs, not only by its poses. A stage whose solve
// does not converge within max_iterations_per_stage after lowering chi2 more
// than tenfold (it started far from its optimum) is redone: its results
// are discarded, its new poses and features unplaced, and the stage is done
// again with half as many new poses (at least min_new_poses; a stage at that
// floor is kept as it is; the stage after a redo adds as many new poses as
// the redo did). Odometry chained over many poses can start them
// outside the optimum's basin, and a window solved from there settles in a
// local minimum the later windows, which hold it fixed, never leave (a
// simulated GPS campus of 500 poses, chi2/dof at the optimum 0.99: 6.2 with
// the 100-pose first stage from dead reckoning, 0.99 with redone stages);
// from a start inside the basin a stage converges within a few iterations
// (Victoria Park, intel, M3500, city10000: 3-7) or starts near its end
// (MRCLAM with a Cauchy kernel), so redoing costs nothing where chaining is
// good. Before stage k the
// poses [T_{k-1}, T_k) are placed by chaining odometry off their optimized
// predecessor and the features first seen from them from that sighting
// (partition/initialization/internal/odometry_chain.h, Table 1 inverted), after each
// odometry stretch of the new poses with two or more GPS fixes is moved onto
// them by a rigid motion (partition/initialization/gps_segment_alignment.h: a window started
// far from its fixes can settle in a local minimum that later windows, which
// hold it fixed, never leave). Stage k then solves the sub-problem W_k:
//   unknown poses  the window [B_k, T_k): the most recent window_poses
//                  poses, cut further to those whose own observations total
//                  at most max_window_observations, and at most
//                  window_observations_per_new times those of the new
//                  poses when set (never cutting into the new poses), plus for
//                  every relative pose or robot sighting from a new pose to a
//                  pose q below the window (a loop closure) the
//                  2 loop_closure_poses + 1 poses centred on q, at most
//                  max_loop_closure_poses of them per stage;
//   unknown features  every feature observed from an unknown pose;
//   fixed poses    the other ends of the unknown poses' constraints, and the
//                  poses of the prior observations below, held at their
//                  current estimates (anchors of the sub-problem's gauge);
//   constraints    every constraint of an unknown pose whose other end is
//                  placed (< T_k); for each unknown feature, its observations
//                  from unknown poses plus at most
//                  max_prior_observations_per_feature of its observations
//                  from poses below the window, evenly spaced in time: they
//                  tie a re-observed feature (a loop closure through a
//                  landmark) to where the earlier trajectory put it.
// and copies the solved unknowns back. Poses outside W_k keep their estimates.
// Full stages: the first stage whose prefix reaches first_poses * g^j
// (g = full_stage_growth, j = 1, 2, ...) solves the whole prefix instead, as
// iSAM's periodic batch steps do: it spreads the drift a loop closure found
// over the whole loop, which a window cannot (Victoria Park with a 500-pose
// window: 3 318.8 without them, 389.787 with them). A full stage with fewer
// than a quarter of its prefix still to come is not made: the caller's full
// solve follows within those poses and does the same job (Victoria Park:
// its full stage at 6 800 of 6 969 poses was 29 % of the initialization's
// time, and the full solve then reaches 389.787 in 4 iterations instead of 2).
//
// Cost. Every window stage's sub-problem has at most window_poses +
// max_loop_closure_poses unknown poses, and at most that many poses' own
// constraints, max_window_observations observations of its window's poses
// (or those of its new poses, if more) and max_prior_observations_per_feature
// observations per unknown feature: bounded independently of the trajectory
// length and of the sensing density. There are O(N / min_new_poses +
// M / max_new_observations) stages (M observations), and the indices (constraints per pose,
// observations per feature) are built once in O(poses + constraints). The
// full stages solve fewer than g / (g - 1) (N + max_new_poses) poses in all.
// So the whole initialization is O(N) stage poses for a bounded number of
// observations per pose (each full stage's linear solve costs what a solve of
// that prefix costs).
// The caller's full solve follows, which corrects what the windows left: the
// drift a loop closure finds before the window stays until then. A redo
// costs one more stage solve, and a stage is redone at most
// log2(max_new_poses / min_new_poses) times (5 with the defaults), so the
// bound stays O(N) stage poses.
//
// The last stage (T_K = N) is solved like the others (so a problem of at most
// first_poses poses is one stage, redone with fewer poses if needed). The
// result is written to problem->poses / problem->features (features marked
// initialized).
//
// Repair. A stage at the floor of min_new_poses is kept even when it leaves
// an odometry step broken (broken_odometry_chi2), and a later window can
// break a step it re-solves; such a fold (internal/broken_odometry.h) is its
// own basin, which the full solve does not leave. So after the last stage
// every odometry step between consecutive poses is checked once more
// (O(N)) against broken_odometry_repair_chi2; the broken ones, grouped into stretches (steps at most
// M = broken_odometry_repair_poses poses apart, first at pose lo, last
// joining pose hi), are each re-solved in the window [lo - M, hi + M]:
// the poses (lo, hi] are chained along the odometry from lo, the features
// they see are placed from their first sighting among them, and the window
// is solved as a stage is (its outer neighbours fixed, at most
// max_prior_observations_per_feature earlier sightings per feature). The
// result replaces the fold when its chi2 is below the window's chi2 as it
// was; else the fold stays. Steps still broken after a round are tried
// again from the improved estimate, three rounds at most. Each stretch
// costs two bounded sub-problems per round (one only evaluated), so the
// repair adds O(stretches) stage solves.
//
// THREAD SAFETY: one call at a time per problem; each stage solve is
// internally parallel (TBB) like SolveGraphSlam and results do not depend on
// the thread count. ALLOCATION: O(poses + features + constraints) for the
// working copies and indices, plus one bounded sub-problem per stage.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "partition/initialization/compact_observations.h"
#include "partition/initialization/prefix_stages.h"

namespace graphslam::partition {

// The schedule (first_poses, solved whole; growth, capped by max_new_poses,
// which must be > 0 here; min_new_poses; max_iterations_per_stage;
// max_observations_per_chunk) is PrefixStageOptions'; the window is this
// initializer's own.
struct IncrementalInitializationOptions : PrefixStageOptions {
  // The most recent poses re-solved by each stage (new poses included);
  // at least max_new_poses.
  int64_t window_poses = 2000;
  // The most observations a window stage re-solves from its window's own
  // poses: the window is cut to the most recent poses whose observations
  // total at most this (never below its new poses). Twice
  // max_new_observations, so that an observation is re-solved in about two
  // stages after its own: the stage cost is the linearization of the
  // window's observations, and older poses, once the later stages have seen
  // their features again, move too little for a longer window to change
  // the start.
  int64_t max_window_observations = 25000;
  // > 0: a window stage also re-solves at most this many times its new
  // poses' observations (never below its new poses), so that a stage redone
  // with fewer new poses re-solves a window of the same proportion, not one
  // of max_window_observations: with sparse sensing (the sampled start's 24
  // observations per pose) a redo with 62 new poses otherwise re-solves the
  // same ~1 000 poses as the 500-pose attempt it replaces. 0: off (only
  // max_window_observations bounds the window).
  double window_observations_per_new = 0.0;
  // The most observations of a stage's new poses (at least one new pose);
  // at most max_window_observations.
  int64_t max_new_observations = 12500;
  // Poses on each side of a loop closure's old end re-solved with the window.
  int64_t loop_closure_poses = 10;
  // At most this many loop-closure poses per stage.
  int64_t max_loop_closure_poses = 500;
  // Observations of an unknown feature from poses below the window kept in
  // the stage (their poses fixed), evenly spaced in time.
  int64_t max_prior_observations_per_feature = 32;
  // Full stages: the first stage whose prefix reaches first_poses * g^j
  // (j = 1, 2, ...) solves the whole prefix (0: never).
  double full_stage_growth = 2.0;
  // > 0: a full stage's relative chi2 decrease to stop at, in place of the
  // caller's function_tolerance (0). Looser suits a start whose whole
  // problem is solved next anyway (the sampled start's sample solve, which
  // stops at 1e-4 itself): a full stage of tens of thousands of poses
  // otherwise spends its last, costliest iterations on decreases below
  // 1e-4 that the next solve makes in passing.
  double full_stage_function_tolerance = 0.0;
  // A stage whose solution leaves one odometry or motion step touching its
  // new poses at a chi2 above this is redone with half its new poses, as a
  // stage started far outside the basin is (internal/broken_odometry.h: a
  // stretch folded over in a local minimum); 0: off. Only solved stages
  // (max_iterations_per_stage > 0) are judged.
  double broken_odometry_chi2 = 1000.0;
  // After the last stage, each stretch of odometry steps above
  // broken_odometry_repair_chi2 (steps at most this many poses apart) is
  // re-chained and re-solved in a window of this many poses on either side,
  // and kept when that beats the fold (header: repair); 0: off.
  int64_t broken_odometry_repair_poses = 50;
  // The repair's bound on one step's chi2, lower than the stage test's: a
  // fold whose end steps carry little information (a robot turning fast,
  // whose velocity-motion information is weak across its arc) costs the
  // odometry only hundreds, which the stage test lets pass, while a step of
  // 3 degrees of freedom that fits exceeds 100 with probability ~1e-20. A
  // false alarm costs one window solve, since a re-solve is kept only when
  // it lowers the window's chi2. 0: the stage test's broken_odometry_chi2.
  double broken_odometry_repair_chi2 = 100.0;

  // The bound the repair applies.
  double RepairChi2() const {
    return broken_odometry_repair_chi2 > 0.0 ? broken_odometry_repair_chi2 : broken_odometry_chi2;
  }

  Status Validate() const;
};

struct IncrementalStageSummary {
  int64_t poses = 0;          // T_k
  bool full = false;          // a full stage (the whole prefix solved)
  int64_t solved_poses = 0;   // unknown poses of W_k
  int64_t fixed_poses = 0;    // poses of W_k held at their estimates
  int64_t features = 0;       // features of W_k
  int64_t observations = 0;   // observations of W_k
  int64_t constraints = 0;    // relative poses, motions, GPS and sightings of W_k
  double initial_chi2 = 0.0;  // of W_k, after placing the new unknowns
  double final_chi2 = 0.0;
  int iterations = 0;
  std::string termination;
  double seconds = 0.0;
};

struct IncrementalSummary {
  bool ran = false;  // false when options.enabled is false
  std::vector<IncrementalStageSummary> stages;  // the stages kept
  int64_t redone_stages = 0;  // stages discarded and done again with fewer new poses
  // Of those, the ones redone for a broken odometry step (broken_odometry_chi2).
  int64_t broken_odometry_redos = 0;
  // Stretches of broken odometry the repair found after the last stage, and
  // those it repaired.
  int64_t broken_odometry_stretches = 0;
  int64_t broken_odometry_repairs = 0;
  double seconds = 0.0;
};

// Replaces the initial guess of *problem (already through
// core::InitializeProblem) by the incremental one described above. `base`
// supplies the solver settings of every stage; its max_iterations is replaced
// by max_iterations_per_stage and its callbacks are not forwarded except
// `progress`, called once per stage with stage "incremental initialization"
// and done/total in poses. On error *problem is unchanged and *summary holds
// the stages done so far.
Status InitializeIncrementally(const IncrementalInitializationOptions& options,
                               const core::SolverOptions& base, core::Problem2d* problem,
                               IncrementalSummary* summary);

// The repair alone (header: repair) on *problem's current estimate, every
// pose and feature of which counts as placed; nothing happens when
// broken_odometry_chi2, broken_odometry_repair_poses or
// max_iterations_per_stage is 0. Counts go to summary's
// broken_odometry_stretches / broken_odometry_repairs.
Status RepairBrokenOdometry(const IncrementalInitializationOptions& options,
                            const core::SolverOptions& base, core::Problem2d* problem,
                            IncrementalSummary* summary);
// The same with the observations in a compact list (the sampled start's
// sample after its solve), none in problem->observations.
Status RepairBrokenOdometry(const IncrementalInitializationOptions& options,
                            const core::SolverOptions& base,
                            const CompactObservations& observations, core::Problem2d* problem,
                            IncrementalSummary* summary);

// The same with the problem's observations held in `observations` (indices
// into *problem's poses and features) and none in problem->observations:
// the sampled start's sample (compact_observations.h), the stages the same
// as from the core::Observation list it compacts.
Status InitializeIncrementally(const IncrementalInitializationOptions& options,
                               const core::SolverOptions& base,
                               const CompactObservations& observations, core::Problem2d* problem,
                               IncrementalSummary* summary);

}  // namespace graphslam::partition
