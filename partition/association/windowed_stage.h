// Windowed stages of the incremental association pass
// (partition/association/incremental_association.h): each stage linearizes,
// tests and solves a window of recent poses instead of the whole prefix, so
// the pass costs O(poses) stage work instead of O(poses^2).
//
// Window. The stage of new poses [b, e) re-solves the poses [B, e), where B
// is the latest pose such that [B, e) holds at least window_poses poses and
// at least window_observations observations (whichever reaches further back;
// never above b), plus the neighbourhoods of the old ends of the new poses'
// loop closures. B = 0 is the whole prefix, as is every full stage: the first
// stage whose prefix reaches full_stage_growth times the last whole one (as
// iSAM's periodic batch steps), and with whole_after_loop_closure the caller
// solves a stage whose loop closure (submap matching, or after a gap) joined
// features whole too: a window cannot spread over the whole loop the drift
// the closure finds. The sub-problem is incremental
// initialization's window sub-problem (partition/initialization/internal/
// window_stage.h): the features seen from the window's poses, each with at
// most max_prior_observations_per_feature earlier sightings from poses held
// fixed, plus the caller's extra features (the old ones a new scan may pair
// with, by their earlier sightings only).
//
// What the window changes. The covariances of the tests are those of the
// window's sub-problem: conditional on the poses held fixed. For two features
// both tied to the window the difference's covariance is the same to first
// order (the fixed poses' common error cancels); for an old feature tied
// only through fixed poses the part of its error that the old trajectory
// shares with the window's start is missing, so revisits are gated tighter
// than the whole prefix would (the loop closure by submap matching and the
// final rounds do not use these covariances). The variance factor and the
// stage undo see the window's chi2.
//
// Cost. With at most W observations per window and k features per scan a
// stage's sub-problem holds O(W + k * max_prior) observations; the full
// stages solve fewer than g / (g - 1) N poses in all (N poses, g =
// full_stage_growth). Building the labelled observation list and its indices
// is O(observations of the prefix) per stage (a copy, no factorization).
//
// THREAD SAFETY: one call at a time per object. ALLOCATION: the indices,
// O(poses + constraints + observations), plus one sub-problem per Build.
#pragma once

#include <cstdint>
#include <vector>

#include "core/problem.h"
#include "core/status.h"
#include "partition/initialization/internal/window_stage.h"

namespace graphslam::partition {

struct StageWindowOptions {
  // Off: every stage solves the whole prefix.
  bool enabled = true;
  // Whichever reaches further back. 6 000 observations hold Victoria Park
  // (3 640) and an MRCLAM robot (4 771 for robot 1) whole; the simulated
  // campus (3.7 observations per pose) is windowed from ~1 600 poses on.
  int64_t window_poses = 1000;
  int64_t window_observations = 6000;
  // Poses on each side of a loop closure's old end re-solved with the window
  // (at most max_loop_closure_poses per stage).
  int64_t loop_closure_poses = 10;
  int64_t max_loop_closure_poses = 500;
  // Earlier sightings of a window feature kept, their poses fixed.
  int64_t max_prior_observations_per_feature = 32;
  // A stage whose prefix reaches this times the last whole one solves the
  // whole prefix (0: never after the window first leaves pose 0).
  double full_stage_growth = 2.0;
  // A stage whose loop closure (submap matching or after a gap) joined
  // features is solved whole: a window cannot spread the drift the closure
  // finds over the loop. Off: on the GPS campus the fixes hold the loop, and
  // its closures (85 stages of 600 at 30 000 poses) made the pass quadratic
  // again (docs/association.md, "Windowed stages").
  bool whole_after_loop_closure = false;

  [[nodiscard]] Status Validate() const;
};

// The first pose of each stage's window (0: the whole prefix), given the
// input's observations per pose as prefix sums.
class StageWindows {
 public:
  // observations_before[p]: observations of poses [0, p), poses + 1 entries.
  StageWindows(const StageWindowOptions& options, const std::vector<int64_t>& observations_before)
      : options_(options), observations_before_(observations_before) {}

  // B for the stage of new poses [begin, end) (file comment); stages are
  // asked in order, once each.
  int32_t Begin(int32_t begin, int32_t end);
  // The stage ending at `end` is solved whole after all (a loop closed in
  // it): 0, and the next full stage is counted from it.
  int32_t Whole(int32_t end) {
    last_whole_ = end;
    return 0;
  }

 private:
  const StageWindowOptions& options_;
  const std::vector<int64_t>& observations_before_;
  int32_t last_whole_ = 0;  // the prefix length of the last whole stage
};

// A window sub-problem and where its unknowns came from.
struct WindowedSubProblem {
  core::Problem2d sub;
  std::vector<int32_t> local_of_label;  // per label: its sub-problem feature, -1 absent
  std::vector<int32_t> unknown_poses;   // the re-solved poses (global indices)
  std::vector<int32_t> local_poses;     // their sub-problem indices, in that order
};

class WindowedStageBuilder {
 public:
  // The pose side of the indices is built once, for every stage.
  WindowedStageBuilder(const StageWindowOptions& options, const core::Problem2d& problem);

  // The sub-problem of the window [window_begin, end) whose new poses start at
  // new_begin: label[o] is input observation o's feature (-1: left out; so is
  // every observation from a pose >= end), positions[l] label l's estimate,
  // extra the labels joined by their earlier sightings only. poses: the
  // current estimate of every pose below end.
  void Build(int32_t window_begin, int32_t new_begin, int32_t end,
             const std::vector<core::Pose2>& poses, const std::vector<int32_t>& label,
             const std::vector<core::Point2>& positions, const std::vector<int32_t>& extra,
             WindowedSubProblem* out);

 private:
  const StageWindowOptions& options_;
  const core::Problem2d& problem_;
  internal::Indices index_;
  std::vector<uint8_t> mark_;  // UnknownPoses' scratch
};

}  // namespace graphslam::partition
