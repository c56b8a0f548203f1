#include "partition/association/association_driver.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <set>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/chunk_passes.h"
#include "core/correspondence_test.h"
#include "core/feature_linearizer.h"
#include "core/logging.h"
#include "core/point_observation_model.h"
#include "core/pose_factors.h"
#include "core/pose_marginals.h"
#include "core/range_bearing_model.h"
#include "core/unknown_layout.h"
#include "partition/association/feature_covariances.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/association/internal/chi_square.h"
#include "partition/association/internal/observation_chi2.h"
#include "partition/association/internal/rejected_pairs.h"
#include "partition/association/internal/variance_factor.h"
#include "partition/initialization/singleton_solve.h"

namespace graphslam::partition {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// Raw (kernel-free) chi2 of one observation.
using internal::ObservationChi2;

core::Point2 FirstSight(const core::Observation& o, const core::Pose2& pose) {
  return core::InvertObservation(o.kind, pose, o.z);
}

using internal::ChiSquareQuantile;

// Gauss-Newton on one feature's position with the poses held, step halving
// while the cost does not decrease: the cheap stand-in for a full re-solve
// after an undo changed which observations the feature has.
void RefitFeature(const core::Problem2d& problem, const std::vector<int32_t>& observations,
                  core::Point2* feature) {
  auto cost = [&](const core::Point2& m) {
    double sum = 0.0;
    for (int32_t o : observations) {
      const core::Observation& obs = problem.observations[o];
      sum += ObservationChi2(obs, problem.poses[obs.pose], m);
    }
    return sum;
  };
  double current = cost(*feature);
  for (int iteration = 0; iteration < 10 && std::isfinite(current); ++iteration) {
    Eigen::Matrix2d h = Eigen::Matrix2d::Zero();
    Eigen::Vector2d g = Eigen::Vector2d::Zero();
    for (int32_t o : observations) {
      const core::Observation& obs = problem.observations[o];
      Eigen::Vector2d e;
      Eigen::Matrix2d j;
      if (!core::EvaluateObservation(obs.kind, problem.poses[obs.pose], *feature, obs.z, &e,
                                     nullptr, &j))
        continue;
      h += j.transpose() * obs.information * j;
      g += j.transpose() * obs.information * e;
    }
    const Eigen::LLT<Eigen::Matrix2d> llt(h);
    if (llt.info() != Eigen::Success) return;
    const Eigen::Vector2d step = -llt.solve(g);
    bool improved = false;
    for (double t = 1.0; t > 1e-3; t *= 0.5) {
      const core::Point2 candidate = *feature + t * step;
      const double c = cost(candidate);
      if (c < current) {
        *feature = candidate;
        improved = current - c > 1e-9 * current;
        current = c;
        break;
      }
    }
    if (!improved) return;
  }
}

struct UnionFind {
  std::vector<int32_t> parent;
  explicit UnionFind(int32_t n) : parent(n) { std::iota(parent.begin(), parent.end(), 0); }
  int32_t Find(int32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
};

struct Candidate {
  int32_t j = 0, k = 0;
  Eigen::Matrix4d joint = Eigen::Matrix4d::Zero();
  core::CorrespondenceResult result;
};

// Joint covariances of every candidate: own noise plus Gamma_j^T Sigma Gamma_k
// (partition/association/feature_covariances.h): each feature whitened once, one sparse
// dot product per pair, pairs in parallel (TBB).
Status JointCovariances(const core::PoseMarginals& marginals, const std::vector<FeatureState>& states,
                        std::vector<Candidate>* candidates) {
  std::vector<int32_t> slot(states.size(), -1);
  std::vector<int32_t> features;
  for (const Candidate& candidate : *candidates) {
    for (int32_t f : {candidate.j, candidate.k}) {
      if (slot[f] < 0) {
        slot[f] = static_cast<int32_t>(features.size());
        features.push_back(f);
      }
    }
  }
  WhitenedFeatures whitened;
  GS_RETURN_IF_ERROR(WhitenFeatures(marginals, states, features, &whitened));
  tbb::parallel_for(tbb::blocked_range<size_t>(0, candidates->size(), 256),
                    [&](const tbb::blocked_range<size_t>& range) {
                      for (size_t c = range.begin(); c != range.end(); ++c) {
                        Candidate& candidate = (*candidates)[c];
                        const int32_t a = slot[candidate.j], b = slot[candidate.k];
                        const Eigen::Matrix2d cross = core::PoseMarginals::Dot(
                            whitened.whitened[a], whitened.whitened[b]);
                        candidate.joint.topLeftCorner<2, 2>() = whitened.covariance[a];
                        candidate.joint.bottomRightCorner<2, 2>() = whitened.covariance[b];
                        candidate.joint.topRightCorner<2, 2>() = cross;
                        candidate.joint.bottomLeftCorner<2, 2>() = cross.transpose();
                      }
                    });
  return Status::Ok();
}

bool SortedIntersect(const std::vector<int32_t>& a, const std::vector<int32_t>& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (a[i] == b[j]) return true;
    if (a[i] < b[j]) ++i; else ++j;
  }
  return false;
}

std::vector<int32_t> SortedUnion(const std::vector<int32_t>& a, const std::vector<int32_t>& b) {
  std::vector<int32_t> out;
  out.reserve(a.size() + b.size());
  std::set_union(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

// The association state: which input feature ("origin") is in which feature.
class Labels {
 public:
  Labels(const core::Problem2d& problem) {
    origin_of_observation_.reserve(problem.observations.size());
    for (const core::Observation& o : problem.observations)
      origin_of_observation_.push_back(o.feature);
    label_.resize(problem.num_features());
    std::iota(label_.begin(), label_.end(), 0);
    origin_ids_ = problem.feature_ids;
  }
  const std::vector<int32_t>& label() const { return label_; }
  int32_t origin_of(size_t observation) const { return origin_of_observation_[observation]; }
  const std::vector<int64_t>& origin_ids() const { return origin_ids_; }

  // Applies label_[origin] := new_label[label_[origin]] and rewrites the
  // problem's features (positions given per new label) and observations.
  void Relabel(const std::vector<int32_t>& new_label, const std::vector<core::Point2>& positions,
               core::Problem2d* problem) {
    for (int32_t& l : label_) l = new_label[l];
    problem->features = positions;
    problem->feature_ids.assign(positions.size(), 0);
    problem->feature_initialized.assign(positions.size(), 1);
    for (size_t o = 0; o < problem->observations.size(); ++o)
      problem->observations[o].feature = label_[origin_of_observation_[o]];
  }

  // Moves the `origins` still in `feature` to a new feature at `position`.
  void SplitOff(const std::vector<int32_t>& origins, int32_t feature,
                const core::Point2& position, core::Problem2d* problem) {
    const int32_t fresh = problem->num_features();
    problem->AddFeature(0, position, /*initialized=*/true);
    for (int32_t origin : origins)
      if (label_[origin] == feature) label_[origin] = fresh;
    for (size_t o = 0; o < problem->observations.size(); ++o)
      problem->observations[o].feature = label_[origin_of_observation_[o]];
  }

 private:
  std::vector<int32_t> origin_of_observation_;
  std::vector<int32_t> label_;  // per origin: current feature index
  std::vector<int64_t> origin_ids_;
};

// Gives the problem's features ids: the smallest input id of each cluster if
// the input had ids (>= 0), else fresh ids above every pose id.
void AssignFeatureIds(const Labels& labels, core::Problem2d* problem) {
  const int32_t n = problem->num_features();
  std::vector<int64_t> ids(n, std::numeric_limits<int64_t>::max());
  bool all_have_ids = true;
  for (size_t origin = 0; origin < labels.label().size(); ++origin) {
    const int64_t id = labels.origin_ids()[origin];
    if (id < 0) all_have_ids = false;
    int64_t& slot = ids[labels.label()[origin]];
    slot = std::min(slot, id);
  }
  if (!all_have_ids) {
    int64_t next = 0;
    for (int64_t id : problem->pose_ids) next = std::max(next, id + 1);
    for (int32_t f = 0; f < n; ++f) ids[f] = next + f;
  }
  problem->feature_ids = ids;
}

// The state the rounds of AssociateAndSolve share.
struct Association {
  const AssociationOptions& options;
  const core::SolverOptions& solver_options;
  core::Problem2d* problem;
  AssociationSummary* summary;
  Labels labels;
  ChunkingOptions chunking;
  internal::RejectedPairs rejected;  // origin pairs never to merge again
};

// Observations of each current feature, for exclusivity and undo.
std::vector<std::vector<int32_t>> ObservationsByFeature(const core::Problem2d& problem) {
  std::vector<std::vector<int32_t>> out(problem.num_features());
  for (size_t o = 0; o < problem.observations.size(); ++o)
    out[problem.observations[o].feature].push_back(static_cast<int32_t>(o));
  return out;
}

std::vector<std::vector<int32_t>> PosesByFeature(const core::Problem2d& problem) {
  std::vector<std::vector<int32_t>> out(problem.num_features());
  for (const core::Observation& o : problem.observations) out[o.feature].push_back(o.pose);
  for (auto& poses : out) {
    std::sort(poses.begin(), poses.end());
    poses.erase(std::unique(poses.begin(), poses.end()), poses.end());
  }
  return out;
}

// Merges features by union-find roots; the merged position is the
// information-weighted mean (C-weighted; equal weights if C is unknown).
void ApplyUnions(UnionFind* sets, const std::vector<FeatureState>* states, Labels* labels,
                 core::Problem2d* problem) {
  const int32_t n = problem->num_features();
  std::vector<int32_t> new_label(n, -1);
  int32_t next = 0;
  for (int32_t f = 0; f < n; ++f) {
    const int32_t root = sets->Find(f);
    if (new_label[root] < 0) new_label[root] = next++;
    new_label[f] = new_label[root];
  }
  std::vector<Eigen::Matrix2d> weight(next, Eigen::Matrix2d::Zero());
  std::vector<Eigen::Vector2d> weighted(next, Eigen::Vector2d::Zero());
  for (int32_t f = 0; f < n; ++f) {
    Eigen::Matrix2d w = Eigen::Matrix2d::Identity();
    if (states != nullptr && (*states)[f].usable) w = (*states)[f].information;
    weight[new_label[f]] += w;
    weighted[new_label[f]] += w * problem->features[f];
  }
  std::vector<core::Point2> positions(next);
  for (int32_t l = 0; l < next; ++l) positions[l] = weight[l].ldlt().solve(weighted[l]);
  labels->Relabel(new_label, positions, problem);
}

// Forced merges (tests): the same path as accepted merges.
Status ApplyForcedMerges(Association* run) {
  core::Problem2d* problem = run->problem;
  UnionFind sets(problem->num_features());
  for (const auto& [a, b] : run->options.forced_merges) {
    if (a < 0 || b < 0 || a >= problem->num_features() || b >= problem->num_features())
      return Status::InvalidArgument("association: forced merge (" + std::to_string(a) + ", " +
                                     std::to_string(b) + ") names a feature outside 0.." +
                                     std::to_string(problem->num_features() - 1));
    MergeRecord record;
    record.forced = true;
    record.probability = std::numeric_limits<double>::quiet_NaN();
    record.feature_a = a;
    record.feature_b = b;
    record.origins_a = {a};
    record.origins_b = {b};
    run->summary->merge_log.push_back(record);
    sets.parent[sets.Find(b)] = sets.Find(a);
  }
  ApplyUnions(&sets, nullptr, &run->labels, problem);
  return Status::Ok();
}

// One undo pass over the merge log, newest merges first; at most one undo per
// feature per re-solve (its other merges may fit again once the worst side is
// gone). `members`: the observations of each feature before the pass;
// *touched marks the features that lost a side. Returns the merges undone.
int64_t UndoPass(int round, bool undone_since_solve, double variance_factor,
                 const std::vector<std::vector<int32_t>>& members, std::vector<uint8_t>* touched,
                 Association* run) {
  core::Problem2d* problem = run->problem;
  Labels& labels = run->labels;
  int64_t undone = 0;
  for (auto it = run->summary->merge_log.rbegin(); it != run->summary->merge_log.rend(); ++it) {
    MergeRecord& record = *it;
    if (record.undone) continue;
    const int32_t feature = labels.label()[record.origins_b.front()];
    if (labels.label()[record.origins_a.front()] != feature) continue;  // split already
    // Features split off in this pass are not in `members`; they are
    // checked after the re-solve.
    if (feature >= static_cast<int32_t>(members.size()) || (*touched)[feature]) continue;
    std::set<int32_t> side_b(record.origins_b.begin(), record.origins_b.end());
    double chi2_a = 0.0, chi2_b = 0.0;
    int64_t count_a = 0, count_b = 0;
    for (int32_t o : members[feature]) {
      const core::Observation& obs = problem->observations[o];
      const double e = ObservationChi2(obs, problem->poses[obs.pose], problem->features[feature]);
      if (side_b.count(labels.origin_of(o))) {
        chi2_b += e;
        ++count_b;
      } else {
        chi2_a += e;
        ++count_a;
      }
    }
    const double s2 = variance_factor;
    const double undo_z = run->options.undo_z;
    const bool bad_b = count_b > 0 && chi2_b > s2 * ChiSquareQuantile(2.0 * count_b, undo_z);
    const bool bad_a = count_a > 0 && chi2_a > s2 * ChiSquareQuantile(2.0 * count_a, undo_z);
    if (!bad_a && !bad_b) continue;
    record.undone = true;
    record.undone_round = round;
    ++undone;
    // A pair undone on re-fitted features (poses held) may come back once a
    // full solve has moved the poses, but not forever; one undone after a
    // full solve never (partition/association/internal/rejected_pairs.h).
    run->rejected.RecordUndo(record.origins_a.front(), record.origins_b.front(),
                             !undone_since_solve);
    // Split side b off into a new feature at the mean of its first sights.
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int64_t count = 0;
    for (int32_t o : members[feature]) {
      if (!side_b.count(labels.origin_of(o))) continue;
      const core::Observation& obs = problem->observations[o];
      sum += FirstSight(obs, problem->poses[obs.pose]);
      ++count;
    }
    labels.SplitOff(record.origins_b, feature, sum / std::max<int64_t>(count, 1), problem);
    (*touched)[feature] = 1;
    GS_LOG(INFO, "association round %d: undid merge of input features %lld and %lld "
           "(chi2 %.3g over %lld and %.3g over %lld observations)",
           round, static_cast<long long>(record.feature_a),
           static_cast<long long>(record.feature_b), chi2_a,
           static_cast<long long>(count_a), chi2_b, static_cast<long long>(count_b));
  }
  return undone;
}

// Solve, then undo merges the solution contradicts, with a full re-solve
// after every undo pass. With refit_between_undos only the features
// concerned are re-fitted between passes (poses held, RefitFeature); the
// full re-solve comes once a pass undoes nothing, and the passes repeat
// until a full solve leaves nothing to undo.
Status SolveAndUndo(int round, AssociationRound* stats, Association* run) {
  const AssociationOptions& options = run->options;
  core::Problem2d* problem = run->problem;
  AssociationSummary* summary = run->summary;
  for (;;) {
    const Clock::time_point solve_start = Clock::now();
    // Features still seen once are left out of the solve (exact, and their
    // linear recovery would spoil the steps: partition/initialization/singleton_solve.h).
    GS_RETURN_IF_ERROR(SolveWithoutSingletons(run->solver_options, run->chunking, problem,
                                              &summary->final_solve));
    stats->solve_seconds += SecondsSince(solve_start);
    stats->chi2 = summary->final_solve.final_chi2;
    ++stats->solves;
    stats->solver_iterations += summary->final_solve.iterations;
    bool undone_since_solve = false;
    // Residuals are judged against the noise the data show (s^2).
    stats->variance_factor =
        options.scale_by_variance_factor
            ? internal::VarianceFactor(*problem, stats->chi2, options.min_redundancy)
            : 1.0;
    for (;;) {
      const std::vector<std::vector<int32_t>> members = ObservationsByFeature(*problem);
      std::vector<uint8_t> touched(problem->num_features() + summary->merge_log.size(), 0);
      const int64_t undone = UndoPass(round, undone_since_solve, stats->variance_factor,
                                      members, &touched, run);
      stats->undone += undone;
      summary->undone += undone;
      if (undone == 0) break;
      undone_since_solve = true;
      if (!options.refit_between_undos) break;  // a full re-solve after every pass
      // Re-fit the features that lost a side and the sides split off.
      const std::vector<std::vector<int32_t>> after = ObservationsByFeature(*problem);
      for (int32_t f = 0; f < problem->num_features(); ++f) {
        if (f < static_cast<int32_t>(members.size()) && !touched[f]) continue;
        RefitFeature(*problem, after[f], &problem->features[f]);
      }
    }
    if (!undone_since_solve) return Status::Ok();
  }
}

// Candidate pairs from a uniform grid hash: usable features within the
// search radius, pose-exclusive if asked, not forbidden by earlier undos.
std::vector<Candidate> FindCandidates(const std::vector<FeatureState>& states,
                                      const std::vector<std::vector<int32_t>>& poses_of,
                                      const Association& run) {
  const AssociationOptions& options = run.options;
  const core::Problem2d& problem = *run.problem;
  std::set<std::pair<int32_t, int32_t>> forbidden_features;
  for (const auto& [a, b] : run.rejected.forbidden())
    forbidden_features.insert(std::minmax(run.labels.label()[a], run.labels.label()[b]));
  const double cell = options.search_radius;
  auto key = [](int64_t x, int64_t y) { return (x << 32) ^ (y & 0xffffffffLL); };
  std::unordered_map<int64_t, std::vector<int32_t>> grid;
  for (int32_t f = 0; f < problem.num_features(); ++f) {
    if (!states[f].usable) continue;
    const auto& p = problem.features[f];
    grid[key(static_cast<int64_t>(std::floor(p.x() / cell)),
             static_cast<int64_t>(std::floor(p.y() / cell)))]
        .push_back(f);
  }
  std::vector<Candidate> candidates;
  const double radius_squared = options.search_radius * options.search_radius;
  for (int32_t f = 0; f < problem.num_features(); ++f) {
    if (!states[f].usable) continue;
    const auto& p = problem.features[f];
    const int64_t cx = static_cast<int64_t>(std::floor(p.x() / cell));
    const int64_t cy = static_cast<int64_t>(std::floor(p.y() / cell));
    for (int64_t dx = -1; dx <= 1; ++dx) {
      for (int64_t dy = -1; dy <= 1; ++dy) {
        const auto it = grid.find(key(cx + dx, cy + dy));
        if (it == grid.end()) continue;
        for (int32_t g : it->second) {
          if (g <= f) continue;
          if ((problem.features[g] - p).squaredNorm() > radius_squared) continue;
          if (options.exclusive_per_pose && SortedIntersect(poses_of[f], poses_of[g])) continue;
          if (forbidden_features.count({f, g})) continue;
          Candidate candidate;
          candidate.j = f;
          candidate.k = g;
          candidates.push_back(candidate);
        }
      }
    }
  }
  return candidates;
}

// The candidates that pass the correspondence test, most probable first; in
// the mutual-best rounds only pairs that are both features' best.
std::vector<int32_t> AcceptCandidates(int round, const AssociationOptions& options,
                                      const core::Problem2d& problem,
                                      std::vector<Candidate>* candidates) {
  std::vector<int32_t> accepted;
  for (size_t c = 0; c < candidates->size(); ++c) {
    Candidate& candidate = (*candidates)[c];
    candidate.result = core::CorrespondenceTest(problem.features[candidate.j],
                                                problem.features[candidate.k], candidate.joint);
    if (candidate.result.valid && candidate.result.probability > options.chi &&
        candidate.result.mahalanobis_squared <= options.max_mahalanobis_squared)
      accepted.push_back(static_cast<int32_t>(c));
  }
  const std::vector<Candidate>& all = *candidates;
  std::stable_sort(accepted.begin(), accepted.end(), [&](int32_t a, int32_t b) {
    return all[a].result.probability > all[b].result.probability;
  });
  if (round <= options.mutual_best_rounds) {
    // Keep a pair only if it is both features' most probable accepted pair.
    std::vector<int32_t> best(problem.num_features(), -1);
    for (int32_t c : accepted) {
      if (best[all[c].j] < 0) best[all[c].j] = c;
      if (best[all[c].k] < 0) best[all[c].k] = c;
    }
    std::erase_if(accepted, [&](int32_t c) { return best[all[c].j] != c || best[all[c].k] != c; });
  }
  return accepted;
}

// Batch merge of the accepted pairs with union-find, clusters kept
// pose-exclusive; each merge logged. Returns the merges.
int64_t MergeAccepted(int round, const std::vector<Candidate>& candidates,
                      const std::vector<int32_t>& accepted,
                      const std::vector<std::vector<int32_t>>& poses_of, UnionFind* sets,
                      Association* run) {
  const std::vector<int32_t>& label = run->labels.label();
  std::vector<std::vector<int32_t>> cluster_poses = poses_of;
  std::vector<std::vector<int32_t>> cluster_origins(run->problem->num_features());
  for (size_t origin = 0; origin < label.size(); ++origin)
    cluster_origins[label[origin]].push_back(static_cast<int32_t>(origin));
  int64_t merges = 0;
  for (int32_t c : accepted) {
    const Candidate& candidate = candidates[c];
    int32_t a = sets->Find(candidate.j);
    int32_t b = sets->Find(candidate.k);
    if (a == b) continue;
    if (run->options.exclusive_per_pose && SortedIntersect(cluster_poses[a], cluster_poses[b]))
      continue;
    if (cluster_origins[a].size() < cluster_origins[b].size()) std::swap(a, b);
    MergeRecord record;
    record.round = round;
    record.feature_a = cluster_origins[a].front();
    record.feature_b = cluster_origins[b].front();
    record.probability = candidate.result.probability;
    record.mahalanobis_squared = candidate.result.mahalanobis_squared;
    record.origins_a = cluster_origins[a];
    record.origins_b = cluster_origins[b];
    run->summary->merge_log.push_back(std::move(record));
    sets->parent[b] = a;
    cluster_poses[a] = SortedUnion(cluster_poses[a], cluster_poses[b]);
    cluster_poses[b].clear();
    cluster_origins[a].insert(cluster_origins[a].end(), cluster_origins[b].begin(),
                              cluster_origins[b].end());
    cluster_origins[b].clear();
    ++merges;
  }
  return merges;
}

// One round: solve and undo, marginals at the solution, candidates, tests,
// merges.
Status RunRound(int round, AssociationRound* stats, Association* run) {
  core::Problem2d* problem = run->problem;
  GS_RETURN_IF_ERROR(SolveAndUndo(round, stats, run));
  stats->features = problem->num_features();

  // Marginals and gains at the solution.
  const Clock::time_point marginal_start = Clock::now();
  InMemoryChunkSource chunks(*problem, run->chunking);
  core::PoseMarginals marginals;
  std::vector<FeatureState> states;
  GS_RETURN_IF_ERROR(
      LinearizeAtSolution(run->solver_options, chunks, *problem, &marginals, &states));
  stats->marginal_seconds += SecondsSince(marginal_start);

  const Clock::time_point association_start = Clock::now();
  const std::vector<std::vector<int32_t>> poses_of = PosesByFeature(*problem);
  std::vector<Candidate> candidates = FindCandidates(states, poses_of, *run);
  stats->candidates = static_cast<int64_t>(candidates.size());
  stats->association_seconds += SecondsSince(association_start);

  const Clock::time_point covariance_start = Clock::now();
  GS_RETURN_IF_ERROR(JointCovariances(marginals, states, &candidates));
  if (stats->variance_factor != 1.0)
    for (Candidate& candidate : candidates) candidate.joint *= stats->variance_factor;
  stats->marginal_seconds += SecondsSince(covariance_start);

  const Clock::time_point test_start = Clock::now();
  const std::vector<int32_t> accepted =
      AcceptCandidates(round, run->options, *problem, &candidates);
  stats->accepted = static_cast<int64_t>(accepted.size());
  UnionFind sets(problem->num_features());
  stats->merges += MergeAccepted(round, candidates, accepted, poses_of, &sets, run);
  if (stats->merges > 0) ApplyUnions(&sets, &states, &run->labels, problem);
  stats->association_seconds += SecondsSince(test_start);
  GS_LOG(INFO, "association round %d: %lld features, %lld candidates, %lld accepted, "
         "%lld merges, %lld undone, chi2 %.9g (solve %.2f s in %lld solves / %lld iterations, "
         "marginals %.2f s, tests %.2f s)",
         round, static_cast<long long>(stats->features), static_cast<long long>(stats->candidates),
         static_cast<long long>(stats->accepted), static_cast<long long>(stats->merges),
         static_cast<long long>(stats->undone), stats->chi2, stats->solve_seconds,
         static_cast<long long>(stats->solves), static_cast<long long>(stats->solver_iterations),
         stats->marginal_seconds, stats->association_seconds);
  return Status::Ok();
}

}  // namespace

Status AssociationOptions::Validate() const {
  if (!(chi >= 0.0) || !std::isfinite(chi))
    return Status::InvalidArgument("association: chi is " + std::to_string(chi) +
                                   "; expected a finite value >= 0");
  if (!(search_radius > 0.0))
    return Status::InvalidArgument("association: search_radius is " +
                                   std::to_string(search_radius) + "; expected > 0");
  if (!(max_mahalanobis_squared > 0.0))
    return Status::InvalidArgument("association: max_mahalanobis_squared must be > 0");
  // A NaN z would make every undo test false (nothing ever split again) and
  // an infinite one the same by an infinite quantile: refused, as the
  // incremental pass refuses its own undo_z.
  if (!std::isfinite(undo_z))
    return Status::InvalidArgument("association: undo_z is " + std::to_string(undo_z) +
                                   "; expected a finite normal quantile z");
  if (max_rounds < 1) return Status::InvalidArgument("association: max_rounds must be >= 1");
  if (marginal_batch < 1) return Status::InvalidArgument("association: marginal_batch must be >= 1");
  if (mutual_best_rounds < 0)
    return Status::InvalidArgument("association: mutual_best_rounds must be >= 0");
  if (full_solve_undos < 1 || full_solve_undos > internal::RejectedPairs::kMaxUndos)
    return Status::InvalidArgument("association: full_solve_undos is " +
                                   std::to_string(full_solve_undos) + "; expected 1 or 2");
  if (chunk_observations < 1)
    return Status::InvalidArgument("association: chunk_observations must be >= 1");
  if (min_redundancy < 0)
    return Status::InvalidArgument("association: min_redundancy must be >= 0");
  GS_RETURN_IF_ERROR(incremental.Validate());
  return Status::Ok();
}

Status TestCorrespondences(const core::SolverOptions& solver_options,
                           const core::Problem2d& problem, int /*marginal_batch*/,
                           std::vector<CorrespondenceQuery>* queries) {
  InMemoryChunkSource chunks(problem, ChunkingOptions());
  core::PoseMarginals marginals;
  std::vector<FeatureState> states;
  GS_RETURN_IF_ERROR(LinearizeAtSolution(solver_options, chunks, problem, &marginals, &states));
  std::vector<Candidate> candidates;
  std::vector<size_t> where;
  for (size_t q = 0; q < queries->size(); ++q) {
    CorrespondenceQuery& query = (*queries)[q];
    query.result = core::CorrespondenceResult();
    if (query.j < 0 || query.k < 0 || query.j >= problem.num_features() ||
        query.k >= problem.num_features() || query.j == query.k)
      return Status::InvalidArgument("TestCorrespondences: pair (" + std::to_string(query.j) +
                                     ", " + std::to_string(query.k) +
                                     ") is not two distinct features");
    if (!states[query.j].usable || !states[query.k].usable) continue;
    Candidate candidate;
    candidate.j = query.j;
    candidate.k = query.k;
    candidates.push_back(candidate);
    where.push_back(q);
  }
  GS_RETURN_IF_ERROR(JointCovariances(marginals, states, &candidates));
  for (size_t c = 0; c < candidates.size(); ++c) {
    CorrespondenceQuery& query = (*queries)[where[c]];
    query.joint_covariance = candidates[c].joint;
    query.result = core::CorrespondenceTest(problem.features[query.j], problem.features[query.k],
                                            candidates[c].joint);
  }
  return Status::Ok();
}

PairwiseScore ScorePairwise(const std::vector<int64_t>& assigned, const std::vector<int64_t>& key) {
  PairwiseScore score;
  auto pairs = [](int64_t n) { return n * (n - 1) / 2; };
  std::unordered_map<int64_t, int64_t> by_assigned, by_key;
  std::unordered_map<int64_t, std::unordered_map<int64_t, int64_t>> joint;
  for (size_t i = 0; i < assigned.size() && i < key.size(); ++i) {
    if (key[i] < 0) continue;
    ++by_assigned[assigned[i]];
    ++by_key[key[i]];
    ++joint[assigned[i]][key[i]];
  }
  for (const auto& [label, count] : by_assigned) score.predicted += pairs(count);
  for (const auto& [label, count] : by_key) score.actual += pairs(count);
  for (const auto& [label, inner] : joint)
    for (const auto& [k, count] : inner) score.true_positive += pairs(count);
  return score;
}

std::vector<int64_t> InputObservationLabels(const core::Problem2d& associated,
                                            const AssociationSummary& summary,
                                            size_t input_observations) {
  std::vector<int64_t> labels(input_observations);
  for (size_t i = 0; i < input_observations; ++i) labels[i] = -1 - static_cast<int64_t>(i);
  for (size_t o = 0; o < associated.observations.size() && o < summary.input_observation.size();
       ++o) {
    const int32_t input = summary.input_observation[o];
    if (input >= 0 && static_cast<size_t>(input) < input_observations)
      labels[input] = associated.observations[o].feature;
  }
  return labels;
}

Status AssociateAndSolve(const AssociationOptions& options,
                         const core::SolverOptions& solver_options, core::Problem2d* problem,
                         AssociationSummary* summary) {
  GS_RETURN_IF_ERROR(options.Validate());
  const Clock::time_point start = Clock::now();
  *summary = AssociationSummary();
  summary->initial_features = problem->num_features();
  GS_RETURN_IF_ERROR(AssociateIncrementally(options.incremental, solver_options, problem,
                                            &summary->incremental,
                                            &summary->input_observation));
  summary->origin_observation.assign(problem->num_features(), -1);
  for (size_t o = problem->observations.size(); o-- > 0;)
    summary->origin_observation[problem->observations[o].feature] = static_cast<int32_t>(o);
  Association run{options, solver_options, problem, summary, Labels(*problem), ChunkingOptions(),
                  internal::RejectedPairs(options.full_solve_undos)};
  run.chunking.max_observations_per_chunk = options.chunk_observations;
  if (!options.forced_merges.empty()) GS_RETURN_IF_ERROR(ApplyForcedMerges(&run));

  for (int round = 1; round <= options.max_rounds; ++round) {
    AssociationRound stats;
    stats.round = round;
    GS_RETURN_IF_ERROR(RunRound(round, &stats, &run));
    summary->rounds.push_back(stats);
    if (stats.merges == 0) {
      summary->converged = true;
      break;
    }
  }
  if (!summary->converged) {
    // The last round merged: solve once more so the returned state is solved.
    GS_RETURN_IF_ERROR(
        SolveWithoutSingletons(solver_options, run.chunking, problem, &summary->final_solve));
  }
  AssignFeatureIds(run.labels, problem);
  summary->final_features = problem->num_features();
  for (const MergeRecord& record : summary->merge_log)
    if (!record.undone) ++summary->merges;
  summary->seconds = SecondsSince(start);
  return Status::Ok();
}

}  // namespace graphslam::partition
