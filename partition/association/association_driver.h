// AssociateAndSolve: GraphSLAM with unknown correspondence (Thrun & Montemerlo
// 2006, Table 10), made efficient the way its caption suggests, plus undo of
// merges (section 6, property 3). docs/association.md has the full story.
//
//   repeat (a round):
//     solve the problem with the current correspondences (Table 5 loop)
//     undo: every earlier merge whose absorbed side's observations no longer
//       fit the merged feature (chi2 of that side above the chi-square
//       quantile for 2 n dof at undo_z, internal/chi_square.h) is split off again, the pair is
//       never proposed again, and the problem is re-solved
//     candidates: feature pairs within `search_radius` of each other (a
//       uniform grid hash of cell size search_radius), not all pairs; pairs
//       whose features were seen from a common pose are skipped (one scan does
//       not see one landmark twice) unless exclusive_per_pose is false
//     test each candidate (Table 9, corrected; core/correspondence_test.h)
//       with the pose covariance blocks it needs (core/pose_marginals.h)
//     accept pi > chi (and squared Mahalanobis distance <= max_mahalanobis_
//       squared); merge the accepted pairs in order of decreasing pi with
//       union-find (a batch), keeping merged clusters pose-exclusive
//     relabel the observations (the in-memory chunks are rebuilt: each
//       feature's observations stay in exactly one chunk)
//   until a round accepts no merge (Table 10 l.17, errata: "pi > chi").
//
// Initial features: one per observation without id (the readers create them),
// placed at first sight by InitializeProblem; features that came with ids are
// treated the same way (they may merge too).
//
// THREAD SAFETY: one call at a time per problem. ALLOCATION: O(observations +
// candidate pairs) plus the CHOLMOD factor of the reduced system and one
// n x 3*marginal_batch block (core/pose_marginals.h).
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/correspondence_test.h"
#include "core/graphslam_solver.h"
#include "core/problem.h"
#include "core/status.h"
#include "partition/association/incremental_association.h"

namespace graphslam::partition {

struct AssociationOptions {
  double chi = 1e-3;                       // accept pi_{j=k} > chi [1/m^2]
  double max_mahalanobis_squared = 13.8155;  // and d^2 below this (chi2, 2 dof, 0.999)
  double search_radius = 5.0;              // candidate pairs closer than this [m]
  int max_rounds = 30;
  bool exclusive_per_pose = true;
  double undo_z = kDefaultGateZ;  // undo when a side's chi2 exceeds the quantile at this normal z
  int marginal_batch = 64;                 // covariance column blocks solved together
  // In rounds 1..mutual_best_rounds a pair merges only if each feature is the
  // other's most probable accepted partner (no chaining of neighbours through
  // a greedy batch); later rounds merge every accepted pair. 0: off.
  int mutual_best_rounds = 0;
  // Between undo passes re-fit only the affected features with the poses held
  // instead of a full re-solve per pass (fewer solves). Pairs undone on such
  // re-fitted features are not forbidden for later rounds. It suits runs
  // whose poses GPS holds, not runs whose poses move between solves.
  bool refit_between_undos = false;
  // Undos right after a full solve that forbid a pair for the rest of the
  // run: 1 forbids it at once; 2 (default) lets it be proposed once more (a
  // right merge undone on a map still bent by wrong ones may come back).
  // Pairs undone on re-fitted features are forbidden at their second undo
  // either way (partition/association/internal/rejected_pairs.h). 2 finds more right
  // merges at equal precision (docs/tuning.md).
  int full_solve_undos = 2;
  // Scale the covariances of the tests, and the undo test's chi2, by the
  // variance factor s^2 of the round's solve (partition/internal/
  // variance_factor.h; 1 below min_redundancy). Off by default (not yet
  // measured on the batch rounds alone).
  bool scale_by_variance_factor = false;
  int64_t min_redundancy = 50;
  int64_t chunk_observations = 4096;
  // The incremental pass before the rounds (id-less inputs only:
  // partition/association/incremental_association.h). Its features are the ones the
  // rounds start from ("input features" of the merge log and forced merges).
  IncrementalAssociationOptions incremental;
  // Merged before the first round regardless of the test (tests of the undo).
  std::vector<std::pair<int32_t, int32_t>> forced_merges;

  [[nodiscard]] Status Validate() const;
};

struct MergeRecord {
  int round = 0;
  int64_t feature_a = 0;  // a representative input feature (index at entry) of each side
  int64_t feature_b = 0;
  double probability = 0.0;  // pi_{j=k}; NaN for forced merges
  double mahalanobis_squared = 0.0;
  bool forced = false;
  bool undone = false;
  int undone_round = 0;
  std::vector<int32_t> origins_b;  // input features of the absorbed side
  std::vector<int32_t> origins_a;  // input features of the other side
};

struct AssociationRound {
  int round = 0;
  int64_t features = 0;    // before the round's merges
  int64_t candidates = 0;  // pairs from the spatial index (after exclusivity)
  int64_t accepted = 0;    // pairs passing the test
  int64_t merges = 0;      // unions made
  int64_t undone = 0;      // earlier merges undone at the start of the round
  double chi2 = 0.0;       // after the round's solve
  double variance_factor = 1.0;  // s^2 of that solve (1 when not scaling)
  double solve_seconds = 0.0;
  double marginal_seconds = 0.0;  // reduced system, factorization, covariance columns
  double association_seconds = 0.0;  // candidates + tests + merges (excluding solves)
  int64_t solves = 0;                // Levenberg-Marquardt solves (1 + re-solves after undos)
  int64_t solver_iterations = 0;     // their iterations
};

struct AssociationSummary {
  int64_t initial_features = 0;
  int64_t final_features = 0;
  int64_t merges = 0;  // not undone
  int64_t undone = 0;
  std::vector<AssociationRound> rounds;
  std::vector<MergeRecord> merge_log;
  core::SolverSummary final_solve;
  IncrementalAssociationSummary incremental;
  // Per observation of the returned problem: its index in the input (the
  // incremental pass drops clutter observations).
  std::vector<int32_t> input_observation;
  // Per feature the rounds started from (index = MergeRecord origins): one of
  // its observations, an index into the returned problem's observations.
  std::vector<int32_t> origin_observation;
  bool converged = false;  // a round accepted nothing (not max_rounds)
  double seconds = 0.0;
};

// `problem` must be initialized (core::InitializeProblem). On return its
// features are the associated ones (ids: the smallest input id of each cluster
// when inputs had ids, else fresh ids above every pose id), every observation
// points to its cluster, and the problem is solved.
Status AssociateAndSolve(const AssociationOptions& options,
                         const core::SolverOptions& solver_options, core::Problem2d* problem,
                         AssociationSummary* summary);

// The correspondence test (Table 9, corrected) for the given feature pairs at
// the problem's current state: linearizes at it (lambda = 0), factorizes the
// reduced system and streams the covariance columns the pairs need. A pair
// with a feature that is excluded or not positive definite gets valid = false.
struct CorrespondenceQuery {
  int32_t j = 0;
  int32_t k = 0;
  Eigen::Matrix4d joint_covariance = Eigen::Matrix4d::Zero();  // of (m_j, m_k)
  core::CorrespondenceResult result;
};
Status TestCorrespondences(const core::SolverOptions& solver_options,
                           const core::Problem2d& problem, int marginal_batch,
                           std::vector<CorrespondenceQuery>* queries);

// Pairwise precision and recall of an association against an answer key:
// over all pairs of observations (with key >= 0), a pair is "predicted" when
// both have the same `assigned` label and "true" when both have the same key.
struct PairwiseScore {
  int64_t true_positive = 0;
  int64_t predicted = 0;
  int64_t actual = 0;
  double precision() const { return predicted > 0 ? double(true_positive) / predicted : 1.0; }
  double recall() const { return actual > 0 ? double(true_positive) / actual : 1.0; }
};
PairwiseScore ScorePairwise(const std::vector<int64_t>& assigned, const std::vector<int64_t>& key);

// The feature of every input observation after AssociateAndSolve, for
// ScorePairwise: observations dropped as clutter get labels of their own
// (-1 - input index), so they pair with nothing.
std::vector<int64_t> InputObservationLabels(const core::Problem2d& associated,
                                            const AssociationSummary& summary,
                                            size_t input_observations);

}  // namespace graphslam::partition
