// AssociateIncrementally: data association scan by scan while the trajectory
// grows stage by stage (the incremental pass before the global Table 10 search
// of partition/association/association_driver.h; docs/association.md).
//
// Input: an id-less problem (every feature has exactly one observation; the
// readers create one per observation without id). Poses are taken in index
// order (time order in every importer), a stage at a time: at least
// `stage_poses` poses and `stage_observations` observations:
//
//   stage [b, e):
//     place the new poses by chaining odometry from the solved prefix
//       (partition/initialization/internal/odometry_chain.h)
//     sub-problem of poses [0, e): the features found so far, one provisional
//       singleton per new observation (first sight, Table 1)
//     with GPS fixes on the new poses (solve_fixes_first): solve the prefix
//       with them first, the new observations left out
//     linearize at that state and factorize the reduced system: every
//       feature's covariance with any other is a sparse dot product
//       (partition/association/feature_covariances.h); the new poses carry the odometry
//       uncertainty of their chain, the old ones that of the map
//     every covariance is scaled by the variance factor of the previous
//       stage solve (scale_by_variance_factor; pooled, or the observations'
//       own with variance_components)
//     for each new pose p with observations (a scan), in order:
//       targets: features (not dropped) whose representative lies within
//         search_radius of one of the scan's observations; a feature already
//         seen in this stage is represented by its latest observation's
//         singleton (closest in time, smallest relative uncertainty), else by
//         its estimate
//       joint assignment of the scan to the targets (JCBB,
//         partition/association/joint_compatibility.h): Mahalanobis gates with the
//         covariance of the difference, exclusive (no two observations of one
//         scan on one feature), most pairings, then smallest joint distance
//       an unpaired observation starts a new, provisional feature
//     loop closure: the local map (features seen in the last local_window
//       poses or local_observations observations before the stage, whichever
//       reaches further, or in it) matched as a rigid whole against
//       the older features (partition/association/submap_matching.h); each inlier pair
//       becomes one feature. This finds revisits after drift larger than
//       any single feature's gate
//     loop closure after a gap (a stretch without observations): the
//       features started after it (the young map) matched as a whole against
//       those started before it, with a larger rotation; when accepted the
//       young map is moved onto the older one, each inlier pair becomes one
//       feature, and the stage undo checks every feature seen on both sides
//       of the gap. Tried at every stage until accepted or until the older
//       features are tracked again
//     the sub-problem is the whole prefix until the stage has a window:
//       from then on every linearization and solve of the stage holds only
//       a window of recent poses (at least window.window_poses poses and
//       window.window_observations observations), the features they see
//       with a few earlier sightings from poses held fixed, and the old
//       features near the stage's new observations; the whole prefix again
//       when it has grown window.full_stage_growth-fold
//       (partition/association/windowed_stage.h). The pass is then linear
//       in poses
//     solve the sub-problem with those correspondences (at most
//       max_iterations_per_stage Levenberg-Marquardt iterations, singletons
//       left out: partition/initialization/singleton_solve.h)
//     undo (undo_stage_pairings): a feature whose older or newly paired
//       observations do not fit the solution loses the stage's observations
//       to a new feature; the stage is solved again
//     a provisional feature (fewer than confirm_observations observations)
//       not seen for provisional_poses poses and provisional_observations
//       observations is dropped as clutter: it is no
//       longer a target, and its observations leave the problem
//   at the end (rescue_provisional): a provisional feature whose sightings
//     fit exactly one confirmed feature at the final estimate joins it
//     (partition/association/provisional_rescue.h); the rest are clutter
//
// Output: *problem holds the solved poses, the confirmed features (ids
// kNoFeatureId; the caller numbers them) and only their observations (input
// order kept); (*input_observation)[k] is the input index of observation k.
// Features still provisional at the end (and not rescued) are clutter too.
// If some feature has more than one observation (an input with ids), nothing
// runs (summary->ran = false) and input_observation is the identity.
//
// THREAD SAFETY: one call at a time per problem; the stage solves and the
// whitening are internally parallel (TBB). ALLOCATION: one prefix
// sub-problem, its chunks and its factor at a time, plus O(observations).
#pragma once

#include <cstdint>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "partition/association/joint_compatibility.h"
#include "partition/association/submap_matching.h"
#include "partition/association/windowed_stage.h"

namespace graphslam::partition {

struct IncrementalAssociationOptions {
  // On by default: it beats the batch rounds alone on Victoria Park, the
  // simulated campus and MRCLAM (docs/association.md, "Measured").
  bool enabled = true;
  // A stage takes new poses until it holds at least stage_poses poses and
  // at least stage_observations observations. At a high sampling rate
  // (50 Hz: 50 poses are one second and a few sightings) poses alone make a
  // stage solve per second of log; stage_observations bounds the stages by
  // the evidence instead. 0 by default: longer stages chain more dead
  // reckoning before each solve, and 25 lowered Victoria Park's recall from
  // 0.986 to 0.505 (docs/association.md).
  int64_t stage_poses = 50;
  int64_t stage_observations = 0;
  // A high-rate log (fewer than sparse_observations_per_pose observations
  // per pose over the input, e.g. MRCLAM at 50 Hz: 0.06) takes stages of at
  // least sparse_stage_observations observations: 50-pose stages would be
  // one prefix solve per second of log (1 500 for a 25-minute log). The
  // inputs above the rate (Victoria Park 0.5, the campus 3.5) keep
  // stage_observations.
  double sparse_observations_per_pose = 0.1;
  int64_t sparse_stage_observations = 25;
  int max_iterations_per_stage = 10;  // LM iterations of each stage solve
  // Initial trust-region radius of each stage solve (the solver's own, if
  // larger): 1/lambda. A stage starts at the previous stage's optimum plus
  // poses chained by odometry, where Gauss-Newton steps fit (rho ~ 1). The
  // solver's cold-start 1e4 damps the slow modes of a long pose chain (their
  // eigenvalues are ~1/n^2 of the diagonal) and, shrinking lambda threefold
  // per step, took the 10 iterations on most Victoria Park stages; a bad
  // step is still rejected and the radius shrunk.
  double stage_initial_trust_region_radius = 1e12;
  double search_radius = 10.0;       // targets closer than this to an observation [m]
  JointCompatibilityOptions joint;   // gates (normal z) and node cap of JCBB
  int confirm_observations = 2;      // fewer observations: provisional
  // A provisional feature is dropped as clutter once it has been unseen for
  // more than provisional_poses poses and provisional_observations
  // observations (of other features) both.
  int64_t provisional_poses = 100;
  int64_t provisional_observations = 50;
  // Before the provisional features left are reported as clutter, each is
  // tested against the confirmed features at the pass's final estimate and
  // joins the only one its sightings fit (chi2 against the quantile for 2n
  // dof at joint.z, times s^2; partition/association/provisional_rescue.h).
  // A tree seen once, then again only after a loop longer than the window,
  // is no misdetection (Victoria Park: 55 of 81 dropped sightings).
  bool rescue_provisional = true;
  // Scale every covariance of the tests (and the stage undo's quantile) by
  // a variance factor once its redundancy reaches min_redundancy, clamped to
  // [1e-4, 1]: the gates then follow the noise the data show, not the
  // inputs' nominal models. By default the pooled s^2 = chi2 / (m - n) of
  // the last stage solve (partition/association/internal/variance_factor.h).
  // With variance_components, the factor of the observations alone,
  // estimated with redundancy numbers at the start of each stage
  // (partition/association/variance_components.h); off by default: it
  // separates the groups (on Victoria Park 0.009 for the observations, 0.04
  // for the odometry), but scaling the whole gate covariance, whose pose
  // part comes from the odometry, by the smaller factor lost recall on
  // Victoria Park and on MRCLAM (docs/association.md).
  bool scale_by_variance_factor = true;
  bool variance_components = false;
  // Not on a high-rate log (below sparse_observations_per_pose): there most
  // re-sightings of a landmark come within a second of each other and share
  // their error, so s^2 measures their scatter, not the error between two
  // visits that the gates must accept (MRCLAM robot 1: s^2 0.10-0.16; with
  // the scaling 0.641 / 0.159, without 0.92 / 0.36; docs/association.md).
  bool scale_high_rate_logs = false;
  int64_t min_redundancy = 50;
  // A stage whose new poses have GPS fixes is solved with them (new
  // observations left out) before its tests: the chained poses do not fit the
  // fixes, yet the covariances include them, so testing the chained means
  // would be over-confident by the dead-reckoning error the fixes remove.
  bool solve_fixes_first = true;
  // Undo inside the pass: after each stage solve, a feature whose older or
  // newly paired observations do not fit the solved estimate (chi2 above the
  // quantile for 2n dof at undo_z, times s^2) loses the stage's
  // observations to a feature of their own; the stage is solved again (at
  // most max_stage_undo_passes times).
  bool undo_stage_pairings = true;
  double undo_z = kDefaultGateZ;
  int max_stage_undo_passes = 2;
  // At the start of each stage, features of the local map (seen since the
  // local window's start) are tested against every feature within
  // search_radius that no pose saw together with them, by Table 9 feature to
  // feature with the stage's covariances (partition/association/
  // duplicate_features.h): a pair compatible at joint.z, with no other
  // compatible partner on either side, is one landmark mapped twice and is
  // joined; the stage undo checks the join after the solve. Off by default:
  // on MRCLAM it trades precision for recall and loses recall early in the
  // log, because most splits there are revisits after more drift than the
  // motion model's covariance allows, and the same covariance keeps the two
  // fragments apart feature to feature too (docs/association.md, "the first
  // failures").
  bool merge_duplicates = false;
  // Loop closure by matching the local map against the older map.
  bool close_loops = true;
  // Features seen in the local_window poses or the local_observations
  // observations before the stage (whichever reaches further back) are local.
  int64_t local_window = 100;
  int64_t local_observations = 50;
  SubmapMatchOptions loop;
  // Loop closure after a gap: once no observation has come for a stretch in
  // which gap_observations would have come at the input's mean rate, the
  // features started after the gap (the young map) are matched as a whole
  // against the features started before it (submap matching with rotations
  // up to gap_max_rotation: the heading a gap without landmarks lets drift).
  // When accepted, the young map's poses and features are moved by the match
  // (the gap's poses by a share of it), each inlier pair becomes one feature,
  // and every feature holding observations from both sides of the gap is
  // checked as the stage undo checks a stage's pairings: the wrong pairings
  // made at the gap's end are split off after the re-solve. Tried at every
  // stage until the next gap.
  bool close_after_gaps = true;
  double gap_observations = 20.0;
  double gap_max_rotation = 1.0;
  int64_t chunk_observations = 4096;
  // The stages' window (partition/association/windowed_stage.h).
  StageWindowOptions window;

  [[nodiscard]] Status Validate() const;
};

struct IncrementalAssociationSummary {
  bool ran = false;
  int64_t stages = 0;
  int64_t scans = 0;                 // poses with observations
  int64_t paired = 0;                // observations given to a feature seen before
  int64_t features = 0;              // confirmed features kept
  int64_t provisional_dropped = 0;   // features never confirmed (clutter)
  int64_t clutter_observations = 0;  // their observations, removed
  int64_t provisional_rescued = 0;   // provisional features joined to a confirmed one at the end
  int64_t exhausted_scans = 0;       // JCBB stopped at max_nodes
  int64_t loop_closures = 0;         // stages whose local map matched the older map
  int64_t loop_pairs = 0;            // local features joined to older ones by them
  int64_t gap_closures = 0;          // young maps matched to the map before a gap
  int64_t gap_pairs = 0;             // young features joined to older ones by them
  int64_t duplicates_merged = 0;     // features joined by the duplicate test
  int64_t stage_undone = 0;          // stage pairings undone after a stage solve
  int64_t windowed_stages = 0;       // stages solved in a window, not the whole prefix
  int64_t largest_window_poses = 0;  // most poses one window re-solved
  double chi2 = 0.0;                 // after the last stage solve
  double variance_factor = 1.0;      // the factor the last gates and undo used
  // Variance components at the start of the last stage (0 when not estimated).
  double observation_variance_factor = 0.0;
  double pose_variance_factor = 0.0;  // odometry, motion, robot range-bearing
  double gps_variance_factor = 0.0;
  double solve_seconds = 0.0;
  double covariance_seconds = 0.0;   // linearization, factorization, whitening
  double assignment_seconds = 0.0;   // targets and JCBB
  double seconds = 0.0;
};

Status AssociateIncrementally(const IncrementalAssociationOptions& options,
                              const core::SolverOptions& solver_options, core::Problem2d* problem,
                              IncrementalAssociationSummary* summary,
                              std::vector<int32_t>* input_observation);

}  // namespace graphslam::partition
