// The window sub-problem of a stage of incremental initialization
// (partition/initialization/incremental_initialization.h) and of the
// incremental association pass (partition/association/windowed_stage.h):
//   unknown poses     a window [B, T) of recent poses plus, for every relative
//                     pose or robot sighting from a new pose to a pose q < B
//                     (a loop closure), the 2 r + 1 poses centred on q
//                     (UnknownPoses);
//   unknown features  every feature observed from an unknown pose (and any
//                     extra ones the caller names);
//   fixed poses       the other ends of the unknown poses' constraints and the
//                     poses of the earlier sightings below, held at their
//                     current estimates;
//   constraints       every constraint of an unknown pose whose other end is
//                     placed (< T); per unknown feature its observations from
//                     unknown poses plus at most max_prior of its sightings
//                     from poses below B, evenly spaced in time (where the
//                     earlier trajectory put it).
// Its size is bounded by the window, not by T, so a stage costs O(window).
// The indices (constraints and observations per pose, observations per
// feature) are compressed rows built in O(poses + constraints + observations).
//
// THREAD SAFETY: a StageBuilder is used by one thread at a time. ALLOCATION:
// O(poses + features + constraints) per builder, plus each sub-problem.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/problem.h"
#include "core/unidentified_features.h"
#include "partition/initialization/compact_observations.h"

namespace graphslam::partition::internal {

using core::Point2;
using core::Pose2;

// Compressed rows: the items of row r are items[offsets[r] .. offsets[r + 1]).
struct Rows {
  std::vector<int64_t> offsets;
  std::vector<int32_t> items;
  int64_t begin(int32_t r) const { return offsets[r]; }
  int64_t end(int32_t r) const { return offsets[r + 1]; }
};

// Rows from (row, item) pairs given by `each(emit)`, items in emission order.
template <class Each>
Rows BuildRows(int32_t num_rows, const Each& each) {
  Rows rows;
  rows.offsets.assign(static_cast<size_t>(num_rows) + 1, 0);
  each([&](int32_t row, int32_t) { ++rows.offsets[row + 1]; });
  for (int32_t r = 0; r < num_rows; ++r) rows.offsets[r + 1] += rows.offsets[r];
  rows.items.resize(static_cast<size_t>(rows.offsets[num_rows]));
  std::vector<int64_t> next(rows.offsets.begin(), rows.offsets.end() - 1);
  each([&](int32_t row, int32_t item) { rows.items[next[row]++] = item; });
  return rows;
}

// A pose-to-pose constraint seen from one of its poses.
enum class EdgeKind : uint8_t { kRelativePose, kMotion, kSighting };
struct PoseLink {
  EdgeKind kind;
  int32_t constraint;
  int32_t other;
};

// The pose and feature of observation k of a list: core::Observation's or
// the sampled start's compact ones (which would expand the whole record).
inline int32_t PoseOf(const std::vector<core::Observation>& observations, int64_t k) {
  return observations[k].pose;
}
inline int32_t PoseOf(const CompactObservations& observations, int64_t k) {
  return observations.pose(k);
}
inline int32_t FeatureOf(const std::vector<core::Observation>& observations, int64_t k) {
  return observations[k].feature;
}
inline int32_t FeatureOf(const CompactObservations& observations, int64_t k) {
  return observations.feature(k);
}

// The per-pose and per-feature indices every stage reads.
struct Indices {
  std::vector<std::vector<PoseLink>> links;  // per pose
  Rows gps_of_pose;
  Rows observations_of_pose;     // input order within a pose
  Rows observations_of_feature;  // increasing pose, then input order
};

// The pose side of the indices (constraints and GPS fixes per pose): fixed
// for a problem.
inline void BuildPoseIndices(const core::Problem2d& problem, Indices* index) {
  const int32_t n = problem.num_poses();
  index->links.assign(n, {});
  auto link = [&](EdgeKind kind, size_t k, int32_t from, int32_t to) {
    if (from == to) return;
    index->links[from].push_back({kind, static_cast<int32_t>(k), to});
    index->links[to].push_back({kind, static_cast<int32_t>(k), from});
  };
  for (size_t k = 0; k < problem.relative_poses.size(); ++k)
    link(EdgeKind::kRelativePose, k, problem.relative_poses[k].from, problem.relative_poses[k].to);
  for (size_t k = 0; k < problem.motions.size(); ++k)
    link(EdgeKind::kMotion, k, problem.motions[k].from, problem.motions[k].to);
  for (size_t k = 0; k < problem.pose_range_bearings.size(); ++k) {
    const core::PoseRangeBearingConstraint& c = problem.pose_range_bearings[k];
    link(EdgeKind::kSighting, k, c.from, c.to);
    // An interpolated sighting also ties the observer to the pose after.
    if (c.interpolated()) link(EdgeKind::kSighting, k, c.from, c.to_next);
  }
  index->gps_of_pose = BuildRows(n, [&](auto emit) {
    for (size_t k = 0; k < problem.gps.size(); ++k)
      emit(problem.gps[k].pose, static_cast<int32_t>(k));
  });
}

// The observation side (observations per pose and per feature) of
// `observations` over num_poses poses and num_features features: rebuilt
// whenever the correspondences change (the incremental association pass).
template <class Observations>
void BuildObservationIndices(int32_t num_poses, int32_t num_features,
                             const Observations& observations, Indices* index) {
  index->observations_of_pose = BuildRows(num_poses, [&](auto emit) {
    for (size_t k = 0; k < observations.size(); ++k)
      emit(PoseOf(observations, k), static_cast<int32_t>(k));
  });
  const Rows& by_pose = index->observations_of_pose;
  index->observations_of_feature = BuildRows(num_features, [&](auto emit) {
    for (int32_t p = 0; p < num_poses; ++p)
      for (int64_t i = by_pose.begin(p); i < by_pose.end(p); ++i)
        emit(FeatureOf(observations, by_pose.items[i]), by_pose.items[i]);
  });
}

template <class Observations>
Indices BuildIndices(const core::Problem2d& problem, const Observations& observations) {
  Indices index;
  BuildPoseIndices(problem, &index);
  BuildObservationIndices(problem.num_poses(), problem.num_features(), observations, &index);
  return index;
}

// One stage's sub-problem W_k (file comment) and where its unknowns came
// from. `Observations` are those of the problem (its own, or a compact list
// when the problem holds none), or any labelling of its observations with
// num_features features whose ids are feature_ids (nullptr: none, the
// sub-problem's features get core::kNoFeatureId).
template <class Observations>
class StageBuilder {
 public:
  StageBuilder(const core::Problem2d& problem, const Observations& observations,
               const Indices& index)
      : StageBuilder(problem, observations, index, problem.num_features(), &problem.feature_ids) {}
  StageBuilder(const core::Problem2d& problem, const Observations& observations,
               const Indices& index, int32_t num_features,
               const std::vector<int64_t>* feature_ids)
      : problem_(problem),
        observations_(observations),
        index_(index),
        feature_ids_(feature_ids),
        local_pose_(problem.poses.size(), -1),
        local_feature_(num_features, -1),
        used_relative_(problem.relative_poses.size(), -1),
        used_motion_(problem.motions.size(), -1),
        used_sighting_(problem.pose_range_bearings.size(), -1),
        used_observation_(observations.size(), -1) {}

  // Builds W_k for the unknown poses `unknown` (ascending, all < t) from the
  // current estimates; `window_begin` is the first pose of the window.
  // `extra_features` (optional) join W_k as unknown features with their
  // earlier sightings only, as a re-observed feature's are taken (the
  // incremental association pass: the old features a new scan may pair with).
  core::Problem2d Build(int32_t stage, const std::vector<int32_t>& unknown, int32_t window_begin,
                        int32_t t, int64_t max_prior, const std::vector<Pose2>& poses,
                        const std::vector<Point2>& features, int64_t* constraints,
                        const std::vector<int32_t>* extra_features = nullptr) {
    Reset();
    core::Problem2d sub;
    sub.source = problem_.source;
    // The unknown poses' own observations, reserved: grown by doubling, the
    // largest stage's (a full stage, which has no earlier sightings to add)
    // would hold its old and new buffers at once.
    int64_t own = 0;
    for (int32_t p : unknown)
      own += index_.observations_of_pose.end(p) - index_.observations_of_pose.begin(p);
    sub.observations.reserve(static_cast<size_t>(own));
    for (int32_t p : unknown) AddPose(p, poses, problem_.pose_fixed[p] != 0, &sub);
    *constraints = 0;
    for (int32_t p : unknown) {
      for (const PoseLink& l : index_.links[p]) {
        if (l.other >= t) continue;  // not placed yet
        if (l.kind == EdgeKind::kSighting &&
            problem_.pose_range_bearings[l.constraint].to_next >= t)
          continue;  // interpolated towards a pose not placed yet
        int32_t& used = l.kind == EdgeKind::kRelativePose ? used_relative_[l.constraint]
                        : l.kind == EdgeKind::kMotion     ? used_motion_[l.constraint]
                                                          : used_sighting_[l.constraint];
        if (used == stage) continue;
        used = stage;
        if (local_pose_[l.other] < 0) AddPose(l.other, poses, true, &sub);
        ++*constraints;
        if (l.kind == EdgeKind::kRelativePose) {
          core::RelativePoseConstraint c = problem_.relative_poses[l.constraint];
          c.from = local_pose_[c.from];
          c.to = local_pose_[c.to];
          sub.relative_poses.push_back(c);
        } else if (l.kind == EdgeKind::kMotion) {
          core::VelocityMotionConstraint c = problem_.motions[l.constraint];
          c.from = local_pose_[c.from];
          c.to = local_pose_[c.to];
          sub.motions.push_back(c);
        } else {
          core::PoseRangeBearingConstraint c = problem_.pose_range_bearings[l.constraint];
          for (const int32_t q : {c.to, c.to_next})  // the third pose, if any
            if (q >= 0 && local_pose_[q] < 0) AddPose(q, poses, true, &sub);
          c.from = local_pose_[c.from];
          c.to = local_pose_[c.to];
          if (c.interpolated()) c.to_next = local_pose_[c.to_next];
          sub.pose_range_bearings.push_back(c);
        }
      }
      for (int64_t i = index_.gps_of_pose.begin(p); i < index_.gps_of_pose.end(p); ++i) {
        core::GpsConstraint c = problem_.gps[index_.gps_of_pose.items[i]];
        c.pose = local_pose_[p];
        sub.gps.push_back(c);
        ++*constraints;
      }
      for (int64_t i = index_.observations_of_pose.begin(p);
           i < index_.observations_of_pose.end(p); ++i)
        AddObservation(stage, index_.observations_of_pose.items[i], poses, features, &sub);
    }
    if (extra_features != nullptr)
      for (int32_t f : *extra_features)
        if (local_feature_[f] < 0) AddFeature(f, features, &sub);
    // Earlier sightings of each unknown feature, evenly spaced below the
    // window, with their poses fixed: where the earlier trajectory put it.
    const size_t unknown_features = features_.size();
    for (size_t j = 0; j < unknown_features; ++j) {
      const int32_t f = features_[j];
      const Rows& rows = index_.observations_of_feature;
      const auto first = rows.items.begin() + rows.begin(f);
      const auto last = std::partition_point(
          first, rows.items.begin() + rows.end(f),
          [&](int32_t k) { return PoseOf(observations_, k) < window_begin; });
      const int64_t below = last - first;
      const int64_t take = std::min(below, max_prior);
      for (int64_t i = 0; i < take; ++i) {
        // The last of them is the most recent sighting before the window.
        const int64_t at = (i + 1) * below / take - 1;
        AddObservation(stage, first[at], poses, features, &sub);
      }
    }
    return sub;
  }

  int32_t local_pose(int32_t p) const { return local_pose_[p]; }
  int32_t local_feature(int32_t f) const { return local_feature_[f]; }
  const std::vector<int32_t>& sub_features() const { return features_; }
  int64_t fixed_poses() const { return fixed_; }

 private:
  void Reset() {
    for (int32_t p : poses_) local_pose_[p] = -1;
    for (int32_t f : features_) local_feature_[f] = -1;
    poses_.clear();
    features_.clear();
    fixed_ = 0;
  }

  void AddPose(int32_t p, const std::vector<Pose2>& poses, bool fixed, core::Problem2d* sub) {
    local_pose_[p] = sub->AddPose(problem_.pose_ids[p], poses[p], true, problem_.pose_lines[p],
                                  problem_.pose_stamps[p]);
    sub->pose_fixed.back() = fixed ? 1 : 0;
    poses_.push_back(p);
    fixed_ += fixed ? 1 : 0;
  }

  void AddFeature(int32_t f, const std::vector<Point2>& features, core::Problem2d* sub) {
    local_feature_[f] = sub->AddFeature(
        feature_ids_ != nullptr ? (*feature_ids_)[f] : core::kNoFeatureId, features[f], true);
    features_.push_back(f);
  }

  void AddObservation(int32_t stage, int32_t k, const std::vector<Pose2>& poses,
                      const std::vector<Point2>& features, core::Problem2d* sub) {
    if (used_observation_[k] == stage) return;
    used_observation_[k] = stage;
    core::Observation o = observations_[k];
    if (local_pose_[o.pose] < 0) AddPose(o.pose, poses, true, sub);
    if (local_feature_[o.feature] < 0) AddFeature(o.feature, features, sub);
    o.pose = local_pose_[o.pose];
    o.feature = local_feature_[o.feature];
    sub->observations.push_back(o);
  }

  const core::Problem2d& problem_;
  const Observations& observations_;
  const Indices& index_;
  const std::vector<int64_t>* feature_ids_;
  std::vector<int32_t> local_pose_, local_feature_;
  // Per constraint: the last stage that took it (each is taken once per stage).
  std::vector<int32_t> used_relative_, used_motion_, used_sighting_, used_observation_;
  std::vector<int32_t> poses_, features_;  // in W_k, global indices, W_k's order
  int64_t fixed_ = 0;
};

// The unknown poses of a stage: the window [window_begin, t) and the
// neighbourhoods of the old ends of the new poses' loop closures
// (loop_closure_poses on each side, at most max_loop_closure_poses).
// `mark` is scratch of one flag per pose, all 0 (left so).
inline std::vector<int32_t> UnknownPoses(int64_t loop_closure_poses, int64_t max_loop_closure_poses,
                                         const Indices& index, int32_t previous,
                                         int32_t window_begin, int32_t t,
                                         std::vector<uint8_t>* mark) {
  std::vector<int32_t> loop;
  const int64_t radius = loop_closure_poses;
  for (int32_t p = std::max(previous, window_begin); p < t; ++p) {
    for (const PoseLink& l : index.links[p]) {
      if (l.kind == EdgeKind::kMotion || l.other >= window_begin) continue;
      const int32_t lo = static_cast<int32_t>(std::max<int64_t>(0, l.other - radius));
      const int32_t hi = static_cast<int32_t>(std::min<int64_t>(window_begin, l.other + radius + 1));
      for (int32_t q = lo; q < hi; ++q) {
        if (static_cast<int64_t>(loop.size()) >= max_loop_closure_poses) break;
        if ((*mark)[q]) continue;
        (*mark)[q] = 1;
        loop.push_back(q);
      }
    }
  }
  for (int32_t q : loop) (*mark)[q] = 0;
  std::sort(loop.begin(), loop.end());
  std::vector<int32_t> unknown = std::move(loop);
  for (int32_t p = window_begin; p < t; ++p) unknown.push_back(p);
  return unknown;
}

}  // namespace graphslam::partition::internal
