#include "partition/association/incremental_association.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <numeric>
#include <string>
#include <unordered_map>
#include <utility>

#include "core/logging.h"
#include "core/point_observation_model.h"
#include "core/pose_marginals.h"
#include "core/range_bearing_model.h"
#include "core/se2.h"
#include "core/unidentified_features.h"
#include "partition/association/duplicate_features.h"
#include "partition/association/feature_covariances.h"
#include "partition/association/provisional_rescue.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/association/internal/chi_square.h"
#include "partition/association/internal/observation_chi2.h"
#include "partition/initialization/internal/odometry_chain.h"
#include "partition/association/internal/variance_factor.h"
#include "partition/association/variance_components.h"
#include "partition/association/windowed_stage.h"
#include "partition/initialization/singleton_solve.h"

namespace graphslam::partition {
namespace {

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

core::Point2 FirstSight(const core::Observation& o, const core::Pose2& pose) {
  return core::InvertObservation(o.kind, pose, o.z);
}

struct Cluster {
  core::Point2 position = core::Point2::Zero();  // estimate after the last stage solve
  std::vector<int32_t> members;                   // input observations
  int32_t first_pose = -1;
  int32_t last_pose = -1;
  bool dropped = false;
  bool absorbed = false;  // joined to an older feature by a loop closure (no members left)
  // In the current stage: the sub-problem feature that represents it in the
  // tests (its latest singleton if seen in this stage) and where it is.
  int32_t representative = -1;
  core::Point2 representative_position = core::Point2::Zero();
};

// The prefix sub-problem of poses [0, end): every cluster not dropped with an
// observation below `end`, and a singleton per unassigned observation of a pose
// in [begin, end) at its first sight. cluster_feature / singleton_feature map
// clusters / input observations to the sub-problem's features (-1: absent).
struct Stage {
  core::Problem2d sub;
  std::vector<int32_t> cluster_feature;
  std::unordered_map<int32_t, int32_t> singleton_feature;
  // A window's sub-problem (BuildRunStage): its re-solved poses and their
  // indices in sub. Empty: sub's poses are the prefix [0, end).
  std::vector<int32_t> unknown_poses, local_poses;
};

Stage BuildStage(const core::Problem2d& problem, const std::vector<core::Pose2>& poses,
                 const std::vector<Cluster>& clusters, const std::vector<int32_t>& cluster_of,
                 int32_t begin, int32_t end) {
  Stage stage;
  core::Problem2d& sub = stage.sub;
  sub.source = problem.source;
  sub.poses.assign(poses.begin(), poses.begin() + end);
  sub.pose_ids.assign(problem.pose_ids.begin(), problem.pose_ids.begin() + end);
  sub.pose_fixed.assign(problem.pose_fixed.begin(), problem.pose_fixed.begin() + end);
  sub.pose_initialized.assign(end, 1);
  sub.pose_lines.assign(problem.pose_lines.begin(), problem.pose_lines.begin() + end);
  sub.pose_stamps.assign(problem.pose_stamps.begin(), problem.pose_stamps.begin() + end);
  for (const core::RelativePoseConstraint& c : problem.relative_poses)
    if (c.from < end && c.to < end) sub.relative_poses.push_back(c);
  for (const core::VelocityMotionConstraint& c : problem.motions)
    if (c.from < end && c.to < end) sub.motions.push_back(c);
  for (const core::GpsConstraint& c : problem.gps)
    if (c.pose < end) sub.gps.push_back(c);
  stage.cluster_feature.assign(clusters.size(), -1);
  for (size_t o = 0; o < problem.observations.size(); ++o) {
    const core::Observation& obs = problem.observations[o];
    if (obs.pose >= end) continue;
    int32_t feature = -1;
    const int32_t c = cluster_of[o];
    if (c >= 0) {
      if (clusters[c].dropped) continue;
      feature = stage.cluster_feature[c];
      if (feature < 0) {
        feature = sub.AddFeature(core::kNoFeatureId, clusters[c].position, true);
        stage.cluster_feature[c] = feature;
      }
    } else {
      if (obs.pose < begin) continue;  // cannot happen: every earlier observation is assigned
      feature = sub.AddFeature(core::kNoFeatureId, FirstSight(obs, poses[obs.pose]), true);
      stage.singleton_feature[static_cast<int32_t>(o)] = feature;
    }
    sub.observations.push_back(obs);
    sub.observations.back().feature = feature;
  }
  return stage;
}

Status CheckInput(const core::Problem2d& problem) {
  const std::string prefix =
      (problem.source.empty() ? std::string("<input>") : problem.source) + ": ";
  const int32_t n = problem.num_poses();
  auto bad = [&](const char* what, int32_t index, int32_t line) {
    const std::string where = line > 0 ? "line " + std::to_string(line) + ": " : "";
    return Status::InvalidArgument(prefix + where + what + " index " + std::to_string(index) +
                                   " out of range, expected 0.." + std::to_string(n - 1));
  };
  for (const core::RelativePoseConstraint& c : problem.relative_poses) {
    if (c.from < 0 || c.from >= n) return bad("relative pose 'from' pose", c.from, c.line);
    if (c.to < 0 || c.to >= n) return bad("relative pose 'to' pose", c.to, c.line);
  }
  for (const core::VelocityMotionConstraint& c : problem.motions) {
    if (c.from < 0 || c.from >= n) return bad("motion 'from' pose", c.from, c.line);
    if (c.to < 0 || c.to >= n) return bad("motion 'to' pose", c.to, c.line);
  }
  for (const core::GpsConstraint& c : problem.gps)
    if (c.pose < 0 || c.pose >= n) return bad("GPS pose", c.pose, c.line);
  for (const core::Observation& o : problem.observations)
    if (o.pose < 0 || o.pose >= n) return bad("observation pose", o.pose, o.line);
  return Status::Ok();
}

// Whitened gains of the stage's features, computed on first use.
class WhitenedCache {
 public:
  WhitenedCache(const core::PoseMarginals& marginals, const std::vector<FeatureState>& states)
      : marginals_(marginals), states_(states), slot_(states.size(), -1) {}

  Status Ensure(const std::vector<int32_t>& features) {
    std::vector<int32_t> missing;
    for (int32_t f : features)
      if (slot_[f] < 0) {
        slot_[f] = -2;
        missing.push_back(f);
      }
    if (missing.empty()) return Status::Ok();
    WhitenedFeatures more;
    GS_RETURN_IF_ERROR(WhitenFeatures(marginals_, states_, missing, &more));
    for (size_t i = 0; i < missing.size(); ++i) {
      slot_[missing[i]] = static_cast<int32_t>(whitened_.whitened.size());
      whitened_.whitened.push_back(std::move(more.whitened[i]));
      whitened_.covariance.push_back(more.covariance[i]);
    }
    return Status::Ok();
  }
  // Sigma_ab of two features (Ensure'd).
  Eigen::Matrix2d Covariance(int32_t a, int32_t b) const {
    if (a == b) return whitened_.covariance[slot_[a]];
    return core::PoseMarginals::Dot(whitened_.whitened[slot_[a]], whitened_.whitened[slot_[b]]);
  }

 private:
  const core::PoseMarginals& marginals_;
  const std::vector<FeatureState>& states_;
  std::vector<int32_t> slot_;
  WhitenedFeatures whitened_;
};

int64_t CellKey(const core::Point2& p, double cell) {
  const int64_t x = static_cast<int64_t>(std::floor(p.x() / cell));
  const int64_t y = static_cast<int64_t>(std::floor(p.y() / cell));
  return (x << 32) ^ (y & 0xffffffffLL);
}

// The grid (cells of side `cell`, CellKey) of the clusters `keep` accepts,
// each cell listing its cluster ids in increasing order.
template <class Keep>
std::unordered_map<int64_t, std::vector<int32_t>> GridOfClusters(
    const std::vector<Cluster>& clusters, double cell, Keep keep) {
  std::unordered_map<int64_t, std::vector<int32_t>> grid;
  for (size_t c = 0; c < clusters.size(); ++c) {
    if (!keep(clusters[c])) continue;
    grid[CellKey(clusters[c].position, cell)].push_back(static_cast<int32_t>(c));
  }
  return grid;
}

// Calls visit(c) for every cluster id in the 3 x 3 cells of `grid` (cells of
// side `cell`, CellKey) around q: every cluster within `cell` of q, and more.
template <class Grid, class Visit>
void ForEachInNearbyCells(const Grid& grid, const core::Point2& q, double cell, Visit visit) {
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      const auto it = grid.find(CellKey(q + core::Point2(dx * cell, dy * cell), cell));
      if (it == grid.end()) continue;
      for (int32_t c : it->second) visit(c);
    }
  }
}


// Whether some pose saw both clusters (then they are two landmarks).
bool SharePose(const core::Problem2d& problem, const Cluster& a, const Cluster& b) {
  auto poses_of = [&](const Cluster& c) {
    std::vector<int32_t> poses;
    for (int32_t o : c.members) poses.push_back(problem.observations[o].pose);
    std::sort(poses.begin(), poses.end());
    return poses;
  };
  const std::vector<int32_t> x = poses_of(a), y = poses_of(b);
  for (size_t i = 0, j = 0; i < x.size() && j < y.size();) {
    if (x[i] == y[j]) return true;
    (x[i] < y[j] ? i : j) += 1;
  }
  return false;
}

// Cluster `from`'s observations go to `to`; `from` is left absorbed.
void JoinCluster(int32_t from_index, int32_t to_index, std::vector<Cluster>* clusters,
                 std::vector<int32_t>* cluster_of) {
  Cluster& from = (*clusters)[from_index];
  Cluster& to = (*clusters)[to_index];
  for (int32_t o : from.members) {
    to.members.push_back(o);
    (*cluster_of)[o] = to_index;
  }
  std::sort(to.members.begin(), to.members.end());
  to.last_pose = std::max(to.last_pose, from.last_pose);
  to.first_pose = std::min(to.first_pose, from.first_pose);
  from.members.clear();
  from.absorbed = true;
  from.representative = -1;
}

// Loop closure of one stage: the local map (clusters seen from pose
// first_local on) against the older confirmed clusters, matched as a rigid
// whole (partition/association/submap_matching.h). Each inlier pair is joined: the local
// cluster's observations go to the older one. Returns the pairs joined.
int64_t CloseLoop(const IncrementalAssociationOptions& options, const core::Problem2d& problem,
                  int32_t begin, int64_t first_local, const std::vector<uint8_t>& solved_before,
                  std::vector<Cluster>* clusters, std::vector<int32_t>* cluster_of) {
  std::vector<int32_t> local_ids, map_ids;
  std::vector<core::Point2> local, map;
  for (size_t c = 0; c < clusters->size(); ++c) {
    const Cluster& cluster = (*clusters)[c];
    if (cluster.dropped || cluster.absorbed || cluster.members.empty()) continue;
    if (cluster.last_pose >= first_local) {
      local_ids.push_back(static_cast<int32_t>(c));
      // Seen before this stage: its solved estimate; new: where it was seen.
      local.push_back(c < solved_before.size() && solved_before[c] ? cluster.position
                                                                    : cluster.representative_position);
    } else if (static_cast<int64_t>(cluster.members.size()) >= options.confirm_observations) {
      map_ids.push_back(static_cast<int32_t>(c));
      map.push_back(cluster.position);
    }
  }
  // One scan never sees one landmark twice: clusters sharing a pose stay apart.
  auto allowed = [&](int32_t l, int32_t a) {
    return !SharePose(problem, (*clusters)[local_ids[l]], (*clusters)[map_ids[a]]);
  };
  const SubmapMatch match = MatchSubmap(local, map, options.loop, allowed);
  if (!match.accepted) {
    if (match.best_inliers >= 3)
      GS_VLOG(2, "incremental association: no loop closure at pose %d: best %d inliers, "
              "runner-up %d, %zu local, %zu older", begin, match.best_inliers,
              match.runner_up_inliers, local.size(), map.size());
    return 0;
  }
  core::Point2 centre = core::Point2::Zero();
  for (const auto& [l, a] : match.pairs) centre += local[l];
  centre /= static_cast<double>(match.pairs.size());
  const double c = std::cos(match.transform.z()), s = std::sin(match.transform.z());
  const core::Point2 moved(c * centre.x() - s * centre.y() + match.transform.x(),
                           s * centre.x() + c * centre.y() + match.transform.y());
  GS_VLOG(1, "incremental association: loop closure at pose %d, %d pairs (runner-up %d), "
          "%zu local, %zu older; the pairs' centre moves %.2f m, %.3f rad", begin,
          match.best_inliers, match.runner_up_inliers, local.size(), map.size(),
          (moved - centre).norm(), match.transform.z());
  for (const auto& [l, a] : match.pairs) {
    if (LogVerbosity() >= 2) {
      std::string text;
      for (int32_t o : (*clusters)[local_ids[l]].members) text.append(" ").append(std::to_string(o));
      text.append(" |");
      for (int32_t o : (*clusters)[map_ids[a]].members) text.append(" ").append(std::to_string(o));
      GS_VLOG(2, "incremental association: loop pair: observations%s", text.c_str());
    }
    JoinCluster(local_ids[l], map_ids[a], clusters, cluster_of);
  }
  return static_cast<int64_t>(match.pairs.size());
}

// False (and OK) unless the input is id-less: one observation per feature.
// Undo of the stage's pairings (property 3 of the search, inside the pass):
// for every cluster that gained observations in the stage while holding
// older ones, the chi2 of each side at the solved estimate is compared with
// the chi-square quantile for 2n degrees of freedom at z = undo_z, scaled by
// the variance factor. If either side does not fit, the stage's side is
// split off into a cluster of its own (at the mean of its first sights): a
// wrong pairing then costs one stage instead of bending every later one.
// Returns the clusters split.
int64_t UndoStagePairings(const IncrementalAssociationOptions& options,
                          const core::Problem2d& problem, const std::vector<core::Pose2>& poses,
                          const std::vector<int32_t>& cluster_before, double scale,
                          std::vector<Cluster>* clusters, std::vector<int32_t>* cluster_of) {
  int64_t undone = 0;
  const size_t existing = clusters->size();
  for (size_t c = 0; c < existing; ++c) {
    Cluster& cluster = (*clusters)[c];
    if (cluster.dropped || cluster.absorbed || cluster.members.size() < 2) continue;
    std::vector<int32_t> old_side, new_side;
    for (int32_t o : cluster.members)
      (cluster_before[o] == static_cast<int32_t>(c) ? old_side : new_side).push_back(o);
    if (old_side.empty() || new_side.empty()) continue;
    auto side_chi2 = [&](const std::vector<int32_t>& side) {
      double sum = 0.0;
      for (int32_t o : side) {
        const core::Observation& obs = problem.observations[o];
        sum += internal::ObservationChi2(obs, poses[obs.pose], cluster.position);
      }
      return sum;
    };
    const auto fits = [&](const std::vector<int32_t>& side) {
      return side_chi2(side) <=
             scale * internal::ChiSquareQuantile(2.0 * static_cast<double>(side.size()),
                                                 options.undo_z);
    };
    if (fits(old_side) && fits(new_side)) continue;
    ++undone;
    Cluster split;
    split.first_pose = problem.observations[new_side.front()].pose;
    core::Point2 sum = core::Point2::Zero();
    for (int32_t o : new_side) {
      const core::Observation& obs = problem.observations[o];
      sum += FirstSight(obs, poses[obs.pose]);
      split.first_pose = std::min(split.first_pose, obs.pose);
      split.last_pose = std::max(split.last_pose, obs.pose);
      (*cluster_of)[o] = static_cast<int32_t>(clusters->size());
    }
    split.position = sum / static_cast<double>(new_side.size());
    split.members = new_side;
    cluster.members = old_side;
    cluster.last_pose = -1;
    cluster.first_pose = problem.observations[old_side.front()].pose;
    for (int32_t o : old_side) {
      cluster.last_pose = std::max(cluster.last_pose, problem.observations[o].pose);
      cluster.first_pose = std::min(cluster.first_pose, problem.observations[o].pose);
    }
    GS_VLOG(2, "incremental association: stage undo splits %zu observations off a feature of %zu",
            new_side.size(), old_side.size());
    clusters->push_back(std::move(split));  // invalidates `cluster`
  }
  return undone;
}

StatusOr<bool> IsIdLess(const core::Problem2d& problem) {
  std::vector<int32_t> count(problem.num_features(), 0);
  for (const core::Observation& o : problem.observations) {
    if (o.feature < 0 || o.feature >= problem.num_features())
      return Status::InvalidArgument(
          (problem.source.empty() ? std::string("<input>") : problem.source) + ": line " +
          std::to_string(o.line) + ": observation feature index " + std::to_string(o.feature) +
          " out of range, expected 0.." + std::to_string(problem.num_features() - 1));
    if (++count[o.feature] > 1) return false;
  }
  return true;
}

// The state the stages of AssociateIncrementally share.
struct IncrementalRun {
  IncrementalRun(const IncrementalAssociationOptions& options_in,
                 const core::SolverOptions& solver_options_in, core::Problem2d* problem_in,
                 IncrementalAssociationSummary* summary_in)
      : options(options_in), solver_options(solver_options_in), problem(problem_in),
        summary(summary_in) {}

  const IncrementalAssociationOptions& options;
  const core::SolverOptions& solver_options;
  core::Problem2d* problem;
  IncrementalAssociationSummary* summary;
  std::vector<std::vector<int32_t>> observations_of_pose;
  // observations_before[p]: observations of poses [0, p) (size poses + 1).
  std::vector<int64_t> observations_before;
  std::vector<core::Pose2> poses;
  std::vector<Cluster> clusters;
  std::vector<int32_t> cluster_of;  // per input observation
  std::vector<uint8_t> has_fix;     // per pose: a GPS fix
  ChunkingOptions chunking;
  core::SolverOptions stage_options;
  double radius_squared = 0.0;
  double scale = 1.0;  // variance factor of the gates and the stage undo
  int64_t stage_observations = 0;  // options.stage_observations, or the high-rate one
  bool scale_gates = true;          // scale_by_variance_factor, unless a high-rate log
  // Gaps: a stretch of more than gap_poses poses without observations. The
  // young map is the features started from pose young_since (the first
  // sighting after the last gap, which began at gap_begin); -1: none open.
  double gap_poses = 0.0;
  int32_t last_seen = -1;
  int32_t gap_begin = -1;
  int32_t young_since = -1;
  bool gap_closed = false;  // the current stage closed a gap
  // The current stage's new poses start at stage_begin; its window at
  // window_begin (0: the whole prefix; partition/association/windowed_stage.h).
  std::unique_ptr<StageWindows> windows;
  std::unique_ptr<WindowedStageBuilder> windowed;
  int32_t stage_begin = 0;
  int32_t window_begin = 0;
};

// The sub-problem of poses [0, end) with a singleton per unassigned
// observation of poses [begin, end): the whole prefix (BuildStage), or the
// stage's window when it has one (partition/association/windowed_stage.h).
// With `targets`, the live clusters within search_radius of a singleton
// join it (by their earlier sightings if the window does not see them):
// every cluster a scan of the stage may be tested against has a covariance.
Stage BuildRunStage(IncrementalRun* run, int32_t begin, int32_t end, bool targets) {
  if (run->window_begin <= 0)
    return BuildStage(*run->problem, run->poses, run->clusters, run->cluster_of, begin, end);
  const core::Problem2d& problem = *run->problem;
  const auto clusters = static_cast<int32_t>(run->clusters.size());
  std::vector<int32_t> label(problem.observations.size(), -1);
  std::vector<core::Point2> positions;
  positions.reserve(clusters);
  for (const Cluster& cluster : run->clusters) positions.push_back(cluster.position);
  std::vector<int32_t> singles;  // the singletons' input observations, label clusters + i
  for (size_t o = 0; o < label.size(); ++o) {
    const core::Observation& obs = problem.observations[o];
    const int32_t c = run->cluster_of[o];
    if (c >= 0) {
      if (!run->clusters[c].dropped) label[o] = c;
    } else if (obs.pose >= begin && obs.pose < end) {
      label[o] = static_cast<int32_t>(positions.size());
      positions.push_back(FirstSight(obs, run->poses[obs.pose]));
      singles.push_back(static_cast<int32_t>(o));
    }
  }
  std::vector<int32_t> extra;
  if (targets && !singles.empty()) {
    const double radius = run->options.search_radius;
    const auto grid = GridOfClusters(run->clusters, radius, [](const Cluster& cluster) {
      return !cluster.dropped && !cluster.absorbed && !cluster.members.empty();
    });
    std::vector<uint8_t> taken(clusters, 0);
    for (size_t s = clusters; s < positions.size(); ++s) {
      ForEachInNearbyCells(grid, positions[s], radius, [&](int32_t c) {
        if (taken[c] || (positions[c] - positions[s]).squaredNorm() > run->radius_squared) return;
        taken[c] = 1;
        extra.push_back(c);
      });
    }
  }
  WindowedSubProblem window;
  run->windowed->Build(run->window_begin, run->stage_begin, end, run->poses, label, positions,
                       extra, &window);
  Stage stage;
  stage.sub = std::move(window.sub);
  stage.cluster_feature.assign(window.local_of_label.begin(),
                               window.local_of_label.begin() + clusters);
  for (size_t i = 0; i < singles.size(); ++i)
    stage.singleton_feature[singles[i]] = window.local_of_label[clusters + i];
  run->summary->largest_window_poses = std::max(
      run->summary->largest_window_poses, static_cast<int64_t>(window.unknown_poses.size()));
  stage.unknown_poses = std::move(window.unknown_poses);
  stage.local_poses = std::move(window.local_poses);
  return stage;
}

// The stage's view of the clusters met so far: the linearization at its
// start, the whitened gains, the grid of cluster positions, and the clusters
// seen (or made) in the stage.
struct StageView {
  Stage stage;
  std::vector<FeatureState> states;
  std::unique_ptr<WhitenedCache> cache;
  std::unordered_map<int64_t, std::vector<int32_t>> grid;
  std::vector<int32_t> touched;
  std::vector<uint8_t> is_touched;
};

// Clusters near any of the scan's singletons (`singles`) whose representative
// has a proper covariance, sorted.
std::vector<int32_t> ScanTargets(const IncrementalRun& run, const StageView& view,
                                 const std::vector<int32_t>& singles) {
  const double radius = run.options.search_radius;
  std::vector<int32_t> targets;
  std::vector<uint8_t> is_target(run.clusters.size(), 0);
  auto consider = [&](int32_t c) {
    const Cluster& cluster = run.clusters[c];
    if (is_target[c] || cluster.dropped || cluster.representative < 0 ||
        !view.states[cluster.representative].usable)
      return;
    for (int32_t s : singles) {
      if ((cluster.representative_position - view.stage.sub.features[s]).squaredNorm() <=
          run.radius_squared) {
        is_target[c] = 1;
        targets.push_back(c);
        return;
      }
    }
  };
  for (int32_t s : singles) {
    ForEachInNearbyCells(view.grid, view.stage.sub.features[s], radius, [&](int32_t c) {
      if (!view.is_touched[c]) consider(c);
    });
  }
  for (int32_t c : view.touched) consider(c);
  std::sort(targets.begin(), targets.end());
  return targets;
}

// Joint compatibility of the scan's tested observations with the targets:
// writes the paired cluster of each tested observation into *assignment.
// *t0 times the assignment; the covariances are timed apart.
Status AssignJointly(const std::vector<int32_t>& singles, const std::vector<size_t>& tested,
                     const std::vector<int32_t>& targets, StageView* view, IncrementalRun* run,
                     Clock::time_point* t0, std::vector<int32_t>* assignment) {
  IncrementalAssociationSummary* summary = run->summary;
  std::vector<int32_t> features;
  for (size_t i : tested) features.push_back(singles[i]);
  for (int32_t c : targets) features.push_back(run->clusters[c].representative);
  summary->assignment_seconds += SecondsSince(*t0);
  *t0 = Clock::now();
  GS_RETURN_IF_ERROR(view->cache->Ensure(features));
  summary->covariance_seconds += SecondsSince(*t0);
  *t0 = Clock::now();
  ScanAssociationInput input;
  input.observations = static_cast<int>(tested.size());
  input.targets = static_cast<int>(targets.size());
  const int k = static_cast<int>(features.size());
  input.covariance.resize(2 * k, 2 * k);
  for (int a = 0; a < k; ++a) {
    input.means.push_back(view->stage.sub.features[features[a]]);
    for (int b = 0; b <= a; ++b) {
      const Eigen::Matrix2d block = run->scale * view->cache->Covariance(features[a], features[b]);
      input.covariance.block<2, 2>(2 * a, 2 * b) = block;
      input.covariance.block<2, 2>(2 * b, 2 * a) = block.transpose();
    }
  }
  const ScanAssignment result = AssignScanJointly(input, run->options.joint);
  if (result.exhausted) ++summary->exhausted_scans;
  for (size_t t = 0; t < tested.size(); ++t)
    if (result.target[t] >= 0) (*assignment)[tested[t]] = targets[result.target[t]];
  return Status::Ok();
}

// The scan of pose p: each observation joins its assigned cluster or starts
// a new one.
Status AssociateScan(int32_t p, StageView* view, IncrementalRun* run, Clock::time_point* t0) {
  const std::vector<int32_t>& scan = run->observations_of_pose[p];
  ++run->summary->scans;
  std::vector<int32_t> singles;
  for (int32_t o : scan) singles.push_back(view->stage.singleton_feature.at(o));
  // Targets near any observation of the scan.
  const std::vector<int32_t> targets = ScanTargets(*run, *view, singles);

  // Observations whose estimate has no proper covariance (excluded by
  // the screening) start features of their own.
  std::vector<int32_t> assignment(scan.size(), -1);
  std::vector<size_t> tested;
  for (size_t i = 0; i < scan.size(); ++i)
    if (view->states[singles[i]].usable) tested.push_back(i);
  if (!targets.empty() && !tested.empty())
    GS_RETURN_IF_ERROR(AssignJointly(singles, tested, targets, view, run, t0, &assignment));
  std::vector<Cluster>& clusters = run->clusters;
  for (size_t i = 0; i < scan.size(); ++i) {
    int32_t c = assignment[i];
    if (c >= 0) {
      ++run->summary->paired;
    } else {
      c = static_cast<int32_t>(clusters.size());
      clusters.emplace_back();
      clusters.back().position = view->stage.sub.features[singles[i]];
      clusters.back().first_pose = p;
      view->is_touched.push_back(0);
    }
    Cluster& cluster = clusters[c];
    cluster.members.push_back(scan[i]);
    cluster.last_pose = p;
    cluster.representative = singles[i];
    cluster.representative_position = view->stage.sub.features[singles[i]];
    run->cluster_of[scan[i]] = c;
    if (!view->is_touched[c]) {
      view->is_touched[c] = 1;
      view->touched.push_back(c);
    }
  }
  return Status::Ok();
}

// The first pose of the local map of a stage starting at `begin`: back by
// local_window poses or local_observations observations, whichever reaches
// further.
int64_t LocalWindowStart(const IncrementalRun& run, int32_t begin) {
  const std::vector<int64_t>& before = run.observations_before;
  const int64_t by_poses = static_cast<int64_t>(begin) - run.options.local_window;
  // The last pose q with at least local_observations observations in [q, begin).
  const int64_t wanted = before[begin] - run.options.local_observations;
  const int64_t by_observations =
      wanted < 0 ? -1
                 : static_cast<int64_t>(std::upper_bound(before.begin(), before.end(), wanted) -
                                        before.begin()) - 1;
  return std::min(by_poses, by_observations);
}

// The end of the stage starting at `begin`: at least stage_poses poses and
// stage_observations observations (or the last pose).
int32_t StageEnd(const IncrementalRun& run, int32_t begin) {
  const std::vector<int64_t>& before = run.observations_before;
  const auto n = static_cast<int64_t>(before.size()) - 1;
  const int64_t by_poses = std::min<int64_t>(n, begin + run.options.stage_poses);
  // The first end with stage_observations observations in [begin, end).
  const int64_t by_observations = static_cast<int64_t>(
      std::lower_bound(before.begin(), before.end(),
                       before[begin] + run.stage_observations) - before.begin());
  return static_cast<int32_t>(std::min(n, std::max(by_poses, by_observations)));
}

// The variance factor of the observations at the stage's start (the
// previous stage's solution; the new poses and singletons fit exactly and add
// no redundancy), for the stage's gates and its undo.
Status ObservationVarianceFactor(const StageView& view, const core::PoseMarginals& marginals,
                                 IncrementalRun* run) {
  VarianceComponents components;
  GS_RETURN_IF_ERROR(EstimateVarianceComponents(view.stage.sub, marginals, view.states,
                                                run->solver_options.observation_kernel,
                                                static_cast<double>(run->options.min_redundancy),
                                                &components));
  run->scale = std::clamp(components.observations.factor, 1e-4, 1.0);
  IncrementalAssociationSummary* summary = run->summary;
  summary->variance_factor = run->scale;
  summary->observation_variance_factor = components.observations.factor;
  summary->pose_variance_factor = components.pose_constraints.factor;
  summary->gps_variance_factor = components.gps.factor;
  GS_VLOG(1, "incremental association: variance factors observations %.4g (chi2 %.6g, r %.1f), "
          "pose constraints %.4g (chi2 %.6g, r %.1f), GPS %.4g (r %.1f)",
          components.observations.factor, components.observations.chi2,
          components.observations.redundancy, components.pose_constraints.factor,
          components.pose_constraints.chi2, components.pose_constraints.redundancy,
          components.gps.factor, components.gps.redundancy);
  return Status::Ok();
}

// Splits healed at the stage's start: each cluster of the local map (seen
// from pose first_local on) against every cluster within search_radius that
// no pose saw with it, by the feature-to-feature test of
// partition/association/duplicate_features.h with the stage's covariances.
// The later cluster of a merged pair joins the earlier one.
Status MergeDuplicateClusters(int64_t first_local, StageView* view, IncrementalRun* run) {
  std::vector<Cluster>& clusters = run->clusters;
  std::vector<int32_t> usable;
  for (size_t c = 0; c < clusters.size(); ++c) {
    const Cluster& cluster = clusters[c];
    if (!cluster.dropped && !cluster.absorbed && !cluster.members.empty() &&
        cluster.representative >= 0 && view->states[cluster.representative].usable)
      usable.push_back(static_cast<int32_t>(c));
  }
  std::vector<int32_t> tested;  // clusters in the test's order
  std::unordered_map<int32_t, int32_t> slot;
  auto slot_of = [&](int32_t c) {
    const auto [it, inserted] = slot.emplace(c, static_cast<int32_t>(tested.size()));
    if (inserted) tested.push_back(c);
    return it->second;
  };
  DuplicateTestInput input;
  for (int32_t l : usable) {
    if (clusters[l].last_pose < first_local) continue;
    for (int32_t a : usable) {
      if (a == l || (clusters[a].last_pose >= first_local && a < l)) continue;  // local pairs once
      if ((clusters[l].position - clusters[a].position).squaredNorm() > run->radius_squared ||
          SharePose(*run->problem, clusters[l], clusters[a]))
        continue;
      input.candidates.emplace_back(slot_of(l), slot_of(a));
    }
  }
  if (input.candidates.empty()) return Status::Ok();
  std::vector<int32_t> features;
  for (int32_t c : tested) features.push_back(clusters[c].representative);
  GS_RETURN_IF_ERROR(view->cache->Ensure(features));
  const int k = static_cast<int>(features.size());
  input.covariance.resize(2 * k, 2 * k);
  for (int a = 0; a < k; ++a) {
    input.means.push_back(clusters[tested[a]].position);
    for (int b = 0; b <= a; ++b) {
      const Eigen::Matrix2d block = run->scale * view->cache->Covariance(features[a], features[b]);
      input.covariance.block<2, 2>(2 * a, 2 * b) = block;
      input.covariance.block<2, 2>(2 * b, 2 * a) = block.transpose();
    }
  }
  const DuplicateTestResult result = FindDuplicateFeatures(input, run->options.joint.z);
  for (const auto& [a, b] : result.merges) {
    const int32_t x = tested[a], y = tested[b];
    GS_VLOG(2, "incremental association: duplicate features %d (%zu observations) and %d (%zu)",
            x, clusters[x].members.size(), y, clusters[y].members.size());
    JoinCluster(std::max(x, y), std::min(x, y), &clusters, &run->cluster_of);
  }
  run->summary->duplicates_merged += static_cast<int64_t>(result.merges.size());
  return Status::Ok();
}

// Moves the poses from the gap on (p < end) and the young map by `move`,
// the map frame after the gap onto the map before it; the gap's poses by a
// growing share of it, so that its odometry takes the change gradually.
void MoveYoungMap(const core::Pose2& move, int32_t end, IncrementalRun* run) {
  auto moved = [&](const core::Point2& point, double share) {
    return core::TransformPoint(core::Pose2(share * move.x(), share * move.y(), share * move.z()),
                                point);
  };
  const int32_t gap = run->young_since - run->gap_begin;
  for (int32_t p = run->gap_begin; p < end; ++p) {
    const double share =
        p >= run->young_since ? 1.0 : static_cast<double>(p - run->gap_begin + 1) / (gap + 1);
    core::Pose2& pose = run->poses[p];
    const core::Point2 xy = moved(pose.head<2>(), share);
    pose = core::Pose2(xy.x(), xy.y(), core::WrapAngle(pose.z() + share * move.z()));
  }
  for (Cluster& cluster : run->clusters) {
    if (cluster.absorbed || cluster.first_pose < run->young_since) continue;
    cluster.position = moved(cluster.position, 1.0);
    cluster.representative_position = moved(cluster.representative_position, 1.0);
  }
}

// Loop closure after a gap: the young map (confirmed clusters started from
// young_since on) matched as a rigid whole against the confirmed clusters
// started before it. When accepted, the young map is moved onto the older
// one and each inlier pair joined; the stage's solve and undo then check
// every feature seen on both sides of the gap (gap_closed).
void CloseGap(int32_t begin, int32_t end, const std::vector<uint8_t>& solved_before,
              IncrementalRun* run) {
  std::vector<Cluster>& clusters = run->clusters;
  std::vector<int32_t> young_ids, old_ids;
  std::vector<core::Point2> young, old;
  for (size_t c = 0; c < clusters.size(); ++c) {
    const Cluster& cluster = clusters[c];
    if (cluster.dropped || cluster.absorbed ||
        static_cast<int64_t>(cluster.members.size()) < run->options.confirm_observations)
      continue;
    if (cluster.first_pose >= run->young_since) {
      young_ids.push_back(static_cast<int32_t>(c));
      young.push_back(c < solved_before.size() && solved_before[c]
                          ? cluster.position
                          : cluster.representative_position);
    } else {
      old_ids.push_back(static_cast<int32_t>(c));
      old.push_back(cluster.position);
    }
  }
  auto allowed = [&](int32_t y, int32_t a) {
    return !SharePose(*run->problem, clusters[young_ids[y]], clusters[old_ids[a]]);
  };
  SubmapMatchOptions match_options = run->options.loop;
  match_options.max_rotation = run->options.gap_max_rotation;
  match_options.distinct_by_pairs = true;
  const SubmapMatch match = MatchSubmap(young, old, match_options, allowed);
  if (!match.accepted) {
    if (match.best_inliers >= 3)
      GS_VLOG(2, "incremental association: gap at poses %d..%d not closed at pose %d: best %d "
              "inliers, runner-up %d, %zu young, %zu older", run->gap_begin, run->young_since - 1,
              begin, match.best_inliers, match.runner_up_inliers, young.size(), old.size());
    return;
  }
  GS_VLOG(1, "incremental association: gap at poses %d..%d closed at pose %d: %d pairs "
          "(runner-up %d), %zu young, %zu older, %.3f rad", run->gap_begin, run->young_since - 1,
          begin, match.best_inliers, match.runner_up_inliers, young.size(), old.size(),
          match.transform.z());
  MoveYoungMap(match.transform, end, run);
  for (const auto& [y, a] : match.pairs)
    JoinCluster(young_ids[y], old_ids[a], &clusters, &run->cluster_of);
  ++run->summary->gap_closures;
  run->summary->gap_pairs += static_cast<int64_t>(match.pairs.size());
  run->gap_closed = true;
}

// Whether the map before the gap is being tracked again: more older clusters
// took observations after the gap than young clusters were confirmed, and at
// least as many as a closure would need. A gap with little drift ends so;
// after one with more drift than the gates allow, the young map grows.
bool YoungMapIsTracked(const IncrementalRun& run, int32_t end) {
  std::vector<uint8_t> counted(run.clusters.size(), 0);
  int64_t older = 0, young = 0;
  for (int32_t p = run.young_since; p < end; ++p) {
    for (int32_t o : run.observations_of_pose[p]) {
      const int32_t c = run.cluster_of[o];
      if (c < 0 || counted[c]) continue;
      counted[c] = 1;
      const Cluster& cluster = run.clusters[c];
      if (cluster.first_pose < run.young_since)
        ++older;
      else if (static_cast<int64_t>(cluster.members.size()) >= run.options.confirm_observations)
        ++young;
    }
  }
  return older > young && older >= run.options.loop.min_inliers;
}

// Pairs the observations of poses [begin, end) with the clusters, scan by
// scan, then closes loops.
Status PairStage(int32_t begin, int32_t end, IncrementalRun* run) {
  IncrementalAssociationSummary* summary = run->summary;
  // Covariances at the stage's start: the prefix solved, the new poses
  // chained (without GPS fixes on them they and their singletons fit their
  // constraints exactly, so this is the optimum of the stage sub-problem
  // before any pairing; with fixes, solved first by SolveFixesFirst).
  Clock::time_point t0 = Clock::now();
  StageView view;
  view.stage = BuildRunStage(run, begin, end, /*targets=*/true);
  InMemoryChunkSource chunks(view.stage.sub, run->chunking);
  core::PoseMarginals marginals;
  GS_RETURN_IF_ERROR(
      LinearizeAtSolution(run->solver_options, chunks, view.stage.sub, &marginals, &view.states)
          .WithContext("incremental association, poses " + std::to_string(begin) + ".." +
                       std::to_string(end - 1)));
  view.cache = std::make_unique<WhitenedCache>(marginals, view.states);
  if (run->scale_gates && run->options.variance_components)
    GS_RETURN_IF_ERROR(ObservationVarianceFactor(view, marginals, run));
  summary->covariance_seconds += SecondsSince(t0);

  t0 = Clock::now();
  for (size_t c = 0; c < run->clusters.size(); ++c) {
    Cluster& cluster = run->clusters[c];
    cluster.representative = view.stage.cluster_feature[c];
    if (cluster.representative >= 0) cluster.representative_position = cluster.position;
  }
  if (run->options.merge_duplicates)
    GS_RETURN_IF_ERROR(MergeDuplicateClusters(LocalWindowStart(*run, begin), &view, run));
  view.grid = GridOfClusters(run->clusters, run->options.search_radius, [](const Cluster& cluster) {
    return !cluster.dropped && !cluster.absorbed && cluster.representative >= 0;
  });
  // The clusters made before the stage.
  const std::vector<uint8_t> solved_before(run->clusters.size(), 1);
  view.is_touched.assign(run->clusters.size(), 0);
  for (int32_t p = begin; p < end; ++p) {
    if (run->observations_of_pose[p].empty()) continue;
    GS_RETURN_IF_ERROR(AssociateScan(p, &view, run, &t0));
  }
  if (run->options.close_loops) {
    const int64_t joined =
        CloseLoop(run->options, *run->problem, begin, LocalWindowStart(*run, begin), solved_before,
                  &run->clusters, &run->cluster_of);
    if (joined > 0) {
      ++summary->loop_closures;
      summary->loop_pairs += joined;
    }
  }
  if (run->options.close_after_gaps && run->young_since >= 0)
    CloseGap(begin, end, solved_before, run);
  summary->assignment_seconds += SecondsSince(t0);
  return Status::Ok();
}

// Solves poses [0, end) with the current clusters (observations not yet
// assigned left out) and takes over the solved poses and positions.
Status SolvePrefix(int32_t end, const char* what, IncrementalRun* run, Stage* solved,
                   core::SolverSummary* solver_summary) {
  const Clock::time_point solve_start = Clock::now();
  *solved = BuildRunStage(run, end, end, /*targets=*/false);
  GS_RETURN_IF_ERROR(
      SolveWithoutSingletons(run->stage_options, run->chunking, &solved->sub, solver_summary)
          .WithContext(std::string("incremental association, ") + what + " of poses " +
                       std::to_string(run->window_begin) + ".." + std::to_string(end - 1)));
  if (solved->unknown_poses.empty()) {
    std::copy(solved->sub.poses.begin(), solved->sub.poses.end(), run->poses.begin());
  } else {
    for (size_t i = 0; i < solved->unknown_poses.size(); ++i)
      run->poses[solved->unknown_poses[i]] = solved->sub.poses[solved->local_poses[i]];
  }
  for (size_t c = 0; c < run->clusters.size(); ++c)
    if (solved->cluster_feature[c] >= 0)
      run->clusters[c].position = solved->sub.features[solved->cluster_feature[c]];
  run->summary->solve_seconds += SecondsSince(solve_start);
  return Status::Ok();
}

// GPS fixes on the new poses: the chained poses do not fit them, and the
// stage's covariances include their information. Testing the chained means
// with those covariances is over-confident by the dead-reckoning error the
// fixes would remove (metres on the simulated campus), so the prefix is
// first solved with the fixes (the new observations are singletons and left
// out): the means then match the covariances.
Status SolveFixesFirst(int32_t begin, int32_t end, IncrementalRun* run) {
  bool new_fixes = false;
  for (int32_t p = begin; p < end && !new_fixes; ++p) new_fixes = run->has_fix[p] != 0;
  if (!new_fixes || !run->options.solve_fixes_first) return Status::Ok();
  core::SolverSummary solver_summary;
  Stage solved;
  return SolvePrefix(end, "GPS solve", run, &solved, &solver_summary);
}

// Solves the prefix [0, end) with its correspondences (poses and cluster
// positions from the solution, the variance factor for the next stage), then
// undoes the stage's pairings the solution rejects and solves again.
Status SolveStage(int32_t end, const std::vector<int32_t>& cluster_before, IncrementalRun* run) {
  IncrementalAssociationSummary* summary = run->summary;
  for (int attempt = 0;; ++attempt) {
    core::SolverSummary solver_summary;
    Stage solved;
    GS_RETURN_IF_ERROR(SolvePrefix(end, "stage solve", run, &solved, &solver_summary));
    summary->chi2 = solver_summary.final_chi2;
    if (run->scale_gates && !run->options.variance_components) {
      run->scale = internal::VarianceFactor(solved.sub, solver_summary.final_chi2,
                                            run->options.min_redundancy);
      summary->variance_factor = run->scale;
    }
    if (!run->options.undo_stage_pairings || attempt >= run->options.max_stage_undo_passes)
      return Status::Ok();
    const int64_t undone = UndoStagePairings(run->options, *run->problem, run->poses,
                                             cluster_before, run->scale, &run->clusters,
                                             &run->cluster_of);
    summary->stage_undone += undone;
    if (undone == 0) return Status::Ok();
  }
}

// Provisional clusters (dropped by the window, or still provisional at the
// end) whose sightings fit exactly one confirmed cluster within search_radius
// at the final estimate join it (partition/association/provisional_rescue.h):
// a first sighting whose next one came after the provisional window is not
// clutter. A cluster that a pose saw together with the provisional one is not
// a candidate. Returns the clusters joined.
int64_t RescueProvisional(IncrementalRun* run) {
  const IncrementalAssociationOptions& options = run->options;
  const core::Problem2d& problem = *run->problem;
  std::vector<Cluster>& clusters = run->clusters;
  const auto confirmed = [&](const Cluster& c) {
    return !c.dropped && !c.absorbed &&
           static_cast<int64_t>(c.members.size()) >= options.confirm_observations;
  };
  const double radius = options.search_radius;
  const auto grid = GridOfClusters(clusters, radius, confirmed);
  int64_t rescued = 0;
  for (size_t p = 0; p < clusters.size(); ++p) {
    const Cluster& cluster = clusters[p];
    if (cluster.absorbed || cluster.members.empty() ||
        static_cast<int64_t>(cluster.members.size()) >= options.confirm_observations)
      continue;
    std::vector<const core::Observation*> sightings;
    for (int32_t o : cluster.members) sightings.push_back(&problem.observations[o]);
    const core::Point2 seen = FirstSight(*sightings.front(), run->poses[sightings.front()->pose]);
    std::vector<int32_t> ids;
    std::vector<core::Point2> positions;
    ForEachInNearbyCells(grid, seen, radius, [&](int32_t c) {
      if ((clusters[c].position - seen).squaredNorm() > run->radius_squared ||
          SharePose(problem, cluster, clusters[c]))
        return;
      ids.push_back(c);
      positions.push_back(clusters[c].position);
    });
    const double gate =
        run->scale * internal::ChiSquareQuantile(2.0 * static_cast<double>(sightings.size()),
                                                 options.joint.z);
    const int32_t k = UniqueCompatibleFeature(sightings, run->poses, positions, gate);
    if (k < 0) continue;
    GS_VLOG(2, "incremental association: provisional feature of %zu observations (pose %d) "
            "joins a confirmed one of %zu", cluster.members.size(), sightings.front()->pose,
            clusters[ids[k]].members.size());
    clusters[p].dropped = false;
    JoinCluster(static_cast<int32_t>(p), ids[k], &clusters, &run->cluster_of);
    ++rescued;
  }
  return rescued;
}

// The map: confirmed features and their observations, input order kept.
void WriteMap(IncrementalRun* run, std::vector<int32_t>* input_observation) {
  core::Problem2d* problem = run->problem;
  IncrementalAssociationSummary* summary = run->summary;
  std::vector<int32_t> index(run->clusters.size(), -1);
  std::vector<core::Point2> features;
  for (size_t c = 0; c < run->clusters.size(); ++c) {
    Cluster& cluster = run->clusters[c];
    if (cluster.absorbed) continue;
    if (static_cast<int64_t>(cluster.members.size()) < run->options.confirm_observations)
      cluster.dropped = true;
    if (cluster.dropped) {
      ++summary->provisional_dropped;
      summary->clutter_observations += static_cast<int64_t>(cluster.members.size());
      continue;
    }
    index[c] = static_cast<int32_t>(features.size());
    features.push_back(cluster.position);
  }
  std::vector<core::Observation> kept;
  input_observation->clear();
  const auto m = static_cast<int64_t>(problem->observations.size());
  for (int64_t o = 0; o < m; ++o) {
    const int32_t f = index[run->cluster_of[o]];
    if (f < 0) continue;
    kept.push_back(problem->observations[o]);
    kept.back().feature = f;
    input_observation->push_back(static_cast<int32_t>(o));
  }
  problem->observations = std::move(kept);
  problem->features = std::move(features);
  problem->feature_ids.assign(problem->features.size(), core::kNoFeatureId);
  problem->feature_initialized.assign(problem->features.size(), 1);
  problem->poses = std::move(run->poses);
}

}  // namespace

Status IncrementalAssociationOptions::Validate() const {
  if (stage_poses < 1)
    return Status::InvalidArgument("incremental association: stage_poses must be >= 1, got " +
                                   std::to_string(stage_poses));
  if (!(stage_initial_trust_region_radius > 0.0))
    return Status::InvalidArgument(
        "incremental association: stage_initial_trust_region_radius must be > 0, got " +
        std::to_string(stage_initial_trust_region_radius));
  if (max_iterations_per_stage < 0)
    return Status::InvalidArgument(
        "incremental association: max_iterations_per_stage must be >= 0, got " +
        std::to_string(max_iterations_per_stage));
  if (!(search_radius > 0.0) || !std::isfinite(search_radius))
    return Status::InvalidArgument("incremental association: search_radius must be finite and "
                                   "> 0, got " + std::to_string(search_radius));
  if (!std::isfinite(joint.z) || joint.max_nodes < 1)
    return Status::InvalidArgument(
        "incremental association: joint.z must be finite and joint.max_nodes >= 1");
  if (confirm_observations < 1)
    return Status::InvalidArgument(
        "incremental association: confirm_observations must be >= 1, got " +
        std::to_string(confirm_observations));
  if (provisional_poses < 0)
    return Status::InvalidArgument("incremental association: provisional_poses must be >= 0, got " +
                                   std::to_string(provisional_poses));
  if (chunk_observations < 1)
    return Status::InvalidArgument(
        "incremental association: chunk_observations must be >= 1");
  if (min_redundancy < 0)
    return Status::InvalidArgument("incremental association: min_redundancy must be >= 0");
  if (!std::isfinite(undo_z) || max_stage_undo_passes < 0)
    return Status::InvalidArgument("incremental association: undo_z must be finite and "
                                   "max_stage_undo_passes >= 0, got " + std::to_string(undo_z) +
                                   " and " + std::to_string(max_stage_undo_passes));
  if (local_window < 0 || local_observations < 0)
    return Status::InvalidArgument(
        "incremental association: local_window and local_observations must be >= 0, got " +
        std::to_string(local_window) + " and " + std::to_string(local_observations));
  if (stage_observations < 0 || provisional_observations < 0 || sparse_stage_observations < 0 ||
      !(sparse_observations_per_pose >= 0.0))
    return Status::InvalidArgument(
        "incremental association: stage_observations, provisional_observations, "
        "sparse_stage_observations and sparse_observations_per_pose must be >= 0, got " +
        std::to_string(stage_observations) + ", " + std::to_string(provisional_observations) +
        ", " + std::to_string(sparse_stage_observations) + " and " +
        std::to_string(sparse_observations_per_pose));
  if (!(gap_observations >= 0.0) || !std::isfinite(gap_observations) ||
      !(gap_max_rotation > 0.0) || !std::isfinite(gap_max_rotation))
    return Status::InvalidArgument(
        "incremental association: gap_observations must be finite and >= 0 and "
        "gap_max_rotation finite and > 0, got " + std::to_string(gap_observations) + " and " +
        std::to_string(gap_max_rotation));
  GS_RETURN_IF_ERROR(window.Validate());
  return loop.Validate();
}

Status AssociateIncrementally(const IncrementalAssociationOptions& options,
                              const core::SolverOptions& solver_options, core::Problem2d* problem,
                              IncrementalAssociationSummary* summary,
                              std::vector<int32_t>* input_observation) {
  *summary = IncrementalAssociationSummary();
  GS_RETURN_IF_ERROR(options.Validate());
  const Clock::time_point start = Clock::now();
  const int64_t m = static_cast<int64_t>(problem->observations.size());
  input_observation->resize(m);
  std::iota(input_observation->begin(), input_observation->end(), 0);
  if (!options.enabled || problem->num_poses() == 0) return Status::Ok();
  GS_ASSIGN_OR_RETURN(const bool id_less, IsIdLess(*problem));
  if (!id_less) return Status::Ok();
  GS_RETURN_IF_ERROR(CheckInput(*problem));
  summary->ran = true;
  const int32_t n = problem->num_poses();

  IncrementalRun run(options, solver_options, problem, summary);
  run.observations_of_pose.resize(n);
  for (int64_t o = 0; o < m; ++o)
    run.observations_of_pose[problem->observations[o].pose].push_back(static_cast<int32_t>(o));
  run.observations_before.assign(static_cast<size_t>(n) + 1, 0);
  for (int32_t p = 0; p < n; ++p)
    run.observations_before[p + 1] =
        run.observations_before[p] + static_cast<int64_t>(run.observations_of_pose[p].size());
  const std::vector<std::vector<internal::PoseEdge>> adjacency =
      internal::OdometryAdjacency(*problem);
  run.poses = problem->poses;
  std::vector<uint8_t> placed(n, 0);
  for (int32_t p = 0; p < n; ++p) placed[p] = problem->pose_fixed[p] != 0;
  run.cluster_of.assign(m, -1);
  run.windows = std::make_unique<StageWindows>(options.window, run.observations_before);
  run.windowed = std::make_unique<WindowedStageBuilder>(options.window, *problem);
  run.has_fix.assign(n, 0);
  for (const core::GpsConstraint& c : problem->gps) run.has_fix[c.pose] = 1;
  run.chunking.max_observations_per_chunk = options.chunk_observations;
  run.stage_options = solver_options;
  run.stage_options.max_iterations = options.max_iterations_per_stage;
  run.stage_options.initial_trust_region_radius =
      std::min(solver_options.max_trust_region_radius,
               std::max(solver_options.initial_trust_region_radius,
                        options.stage_initial_trust_region_radius));
  run.stage_options.progress = nullptr;
  run.stage_options.iteration_callback = nullptr;
  run.radius_squared = options.search_radius * options.search_radius;
  run.stage_observations = options.stage_observations;
  run.scale_gates = options.scale_by_variance_factor;
  run.gap_poses = m > 0 ? options.gap_observations * static_cast<double>(n) / static_cast<double>(m)
                        : 0.0;
  if (static_cast<double>(m) < options.sparse_observations_per_pose * n) {
    run.stage_observations = std::max(run.stage_observations, options.sparse_stage_observations);
    run.scale_gates = run.scale_gates && options.scale_high_rate_logs;
  }

  for (int32_t begin = 0; begin < n;) {
    const int32_t end = StageEnd(run, begin);
    internal::PlacePoses(*problem, adjacency, begin, end, &run.poses, &placed);
    ++summary->stages;
    bool any_new = false;
    for (int32_t p = begin; p < end && !any_new; ++p)
      any_new = !run.observations_of_pose[p].empty();
    // Pair, then solve the stage with its correspondences (nothing to do
    // without new observations: the chained poses already fit their odometry).
    if (any_new) {
      // Cluster of every observation before this stage's pairings (the undo
      // tells the pairings made in the stage from the older members).
      std::vector<int32_t> cluster_before = run.cluster_of;
      for (int32_t p = begin; p < end; ++p) {
        if (run.observations_of_pose[p].empty()) continue;
        if (run.young_since < 0 && run.last_seen >= 0 &&
            static_cast<double>(p - run.last_seen - 1) > run.gap_poses) {
          run.gap_begin = run.last_seen + 1;
          run.young_since = p;
          GS_VLOG(1, "incremental association: no observation in poses %d..%d: young map from %d",
                  run.gap_begin, p - 1, p);
        }
        run.last_seen = p;
      }
      run.stage_begin = begin;
      run.window_begin = run.windows->Begin(begin, end);
      GS_RETURN_IF_ERROR(SolveFixesFirst(begin, end, &run));
      run.gap_closed = false;
      const int64_t closures = summary->loop_closures + summary->gap_closures;
      GS_RETURN_IF_ERROR(PairStage(begin, end, &run));
      // A loop closed in the stage bends the old map too: solved whole (the
      // window's tests are done).
      if (options.window.whole_after_loop_closure &&
          summary->loop_closures + summary->gap_closures > closures)
        run.window_begin = run.windows->Whole(end);
      if (run.window_begin > 0) ++summary->windowed_stages;
      if (run.gap_closed) {
        // Every observation after the gap is checked against the older ones
        // of its feature, as the stage's own pairings are.
        for (size_t o = 0; o < cluster_before.size(); ++o)
          if (problem->observations[o].pose >= run.gap_begin) cluster_before[o] = -1;
        run.young_since = -1;
      }
      GS_RETURN_IF_ERROR(SolveStage(end, cluster_before, &run));
      if (run.young_since >= 0 && YoungMapIsTracked(run, end)) {
        GS_VLOG(1, "incremental association: the map before the gap is tracked again by pose %d",
                end - 1);
        run.young_since = -1;
      }
      // Diagnosis: the stage's poses as solved then, and where its
      // observations went (what later stages and closures did not yet change).
      if (LogVerbosity() >= 3) {
        for (int32_t p = begin; p < end; ++p) {
          if (run.observations_of_pose[p].empty()) continue;
          const double stamp =
              static_cast<size_t>(p) < problem->pose_stamps.size() ? problem->pose_stamps[p] : 0.0;
          GS_VLOG(3, "trace pose %d %.3f %.4f %.4f %.5f", p, stamp, run.poses[p].x(),
                  run.poses[p].y(), run.poses[p].z());
          for (int32_t o : run.observations_of_pose[p])
            GS_VLOG(3, "trace obs %d %d %.4f %.5f", o, run.cluster_of[o],
                    problem->observations[o].z.x(), problem->observations[o].z.y());
        }
      }
    }

    // Provisional features not seen for a while are clutter.
    for (Cluster& cluster : run.clusters) {
      if (cluster.dropped || cluster.absorbed ||
          static_cast<int64_t>(cluster.members.size()) >= options.confirm_observations)
        continue;
      const int64_t unseen_observations =
          run.observations_before[end] - run.observations_before[cluster.last_pose + 1];
      if (static_cast<int64_t>(end) - cluster.last_pose > options.provisional_poses &&
          unseen_observations > options.provisional_observations)
        cluster.dropped = true;
    }
    GS_VLOG(1, "incremental association: poses 0..%d, %zu features, %lld paired, chi2 %.6g, "
            "variance factor %.4g", end - 1, run.clusters.size(),
            static_cast<long long>(summary->paired), summary->chi2, run.scale);
    begin = end;
  }
  if (options.rescue_provisional) summary->provisional_rescued = RescueProvisional(&run);
  WriteMap(&run, input_observation);
  summary->features = problem->num_features();
  summary->seconds = SecondsSince(start);
  return Status::Ok();
}

}  // namespace graphslam::partition
