// MatchSubmap: closes a loop after long dead reckoning by matching a local
// map (the features seen in the last poses) against the older map as a
// rigid whole, where single features are too far apart for any per-feature
// gate (docs/association.md, "Loop closure by submap matching").
//
// Points: local l_0..l_{n-1} and map m_0..m_{k-1} in one frame. The local map
// is internally consistent (dead-reckoned over a short stretch) but may be
// displaced from the old map by the drift accumulated since, up to
// `search_radius`. A hypothesis is a rigid transform T(l) = R(theta) l + t:
//
//   two local points (i, j) and two map points (a, b) with a within
//   search_radius of l_i, b of l_j, and | |l_i - l_j| - |m_a - m_b| | <=
//   tolerance give theta = angle(m_b - m_a) - angle(l_j - l_i) (|theta| <=
//   max_rotation) and t mapping the midpoint of (l_i, l_j) onto that of
//   (m_a, m_b);
//   its inliers: each local point paired with the nearest unused map point
//   within `tolerance` of T(l) (closest pairs first; one map point per local
//   point and vice versa), among the pairs `allowed` admits;
//   the transform is refitted to its inliers (least squares, Procrustes:
//   theta from the cross-covariance of the centred point sets) and the
//   inliers counted once more.
//
// Answer: the hypothesis with the most inliers (ties: the smallest sum of
// squared residuals), accepted only when it has at least min_inliers and no
// distinct hypothesis (one that moves some inlier of the best by more than
// tolerance, or with distinct_by_pairs one sharing fewer than half of its
// pairs) comes within ambiguity_margin inliers of it: a row of evenly
// spaced trees fits one spacing along as well, and then nothing is matched.
// Every pair of points is tried, so the result is deterministic.
//
// THREAD SAFETY: a pure function. ALLOCATION: O(n + k) plus the candidate
// lists; time O(P^2 c^2 n c) for P local points with at most c map
// candidates each.
#pragma once

#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "core/se2.h"
#include "core/status.h"

namespace graphslam::partition {

struct SubmapMatchOptions {
  double search_radius = 20.0;   // largest displacement of the local map [m]
  double tolerance = 1.0;        // inlier distance after the transform [m]
  int min_inliers = 4;           // fewer: no loop closure
  int ambiguity_margin = 2;      // a distinct runner-up this close: no closure
  double max_rotation = 0.5;     // largest heading drift [rad]
  double min_pair_distance = 2.0;  // hypothesis pairs at least this far apart [m]
  // What makes a hypothesis distinct from the best: false, moving some inlier
  // of the best by more than tolerance; true, sharing fewer than half of the
  // best's pairs. A large map rotated a little moves its far points by more
  // than the tolerance yet pairs them as the best does: with many points
  // only a different pairing is another explanation.
  bool distinct_by_pairs = false;

  [[nodiscard]] Status Validate() const;
};

struct SubmapMatch {
  bool accepted = false;
  std::vector<std::pair<int32_t, int32_t>> pairs;  // (local, map) inliers when accepted
  core::Pose2 transform = core::Pose2::Zero();     // (t_x, t_y, theta) of the best hypothesis
  int best_inliers = 0;
  int runner_up_inliers = 0;  // inliers of the best distinct hypothesis
};

// allowed(local, map) may forbid pairs (e.g. two features seen from one
// pose); nullptr allows all.
SubmapMatch MatchSubmap(const std::vector<core::Point2>& local,
                        const std::vector<core::Point2>& map, const SubmapMatchOptions& options,
                        const std::function<bool(int32_t, int32_t)>& allowed = nullptr);

}  // namespace graphslam::partition
