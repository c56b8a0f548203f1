// UnknownLayout: which poses are unknowns of the reduced system, and where.
//
// The gauge is fixed by removing anchored poses from the unknowns (never by a
// huge "infinite" prior, which would ruin PCG's conditioning):
// poses marked fixed are anchors; when none is fixed and no GPS constraint ties
// the map to the world, pose 0 is the anchor. Free pose p owns the block
// unknown_index[p] of the pose block size (3 in the plane, 6 in 3-D:
// core/problem_space.h) in the increment vector dx; anchored poses have -1.
//
// Features with very many observations are not eliminated: a feature seen from
// k poses would fill k^2 pose blocks of the reduced matrix. Such "kept"
// features stay unknowns of the reduced system, after the poses, as blocks of
// the pose block size whose components past the feature dimension are a
// decoupled pad (information 1, gradient 0, so their step is exactly 0).
// feature_unknown_index[f] is the block of kept feature f, or -1 (empty when
// no feature is kept).
//
// THREAD SAFETY: a plain value. ALLOCATION: O(poses).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/problem.h"
#include "core/problem_3d.h"

namespace graphslam::core {

struct UnknownLayout {
  static constexpr int kPoseDimension = 3;  // the planar pose block (Space2d::kPoseDim)
  std::vector<int32_t> unknown_index;  // per pose: block index, or -1 if anchored
  int32_t num_unknown_poses = 0;
  int32_t num_anchored = 0;
  bool anchored_by_gps = false;
  std::vector<int32_t> feature_unknown_index;  // per feature: block, or -1 if eliminated/excluded
  int32_t num_kept_features = 0;

  int32_t num_blocks() const { return num_unknown_poses + num_kept_features; }

  // Makes the features with keep[f] != 0 unknowns of the reduced system.
  // With none kept (the usual case) feature_unknown_index stays empty and
  // IsKept is false for every feature: 4 B per feature not held.
  void KeepFeatures(const std::vector<uint8_t>& keep) {
    std::vector<int32_t>().swap(feature_unknown_index);
    num_kept_features = 0;
    if (std::none_of(keep.begin(), keep.end(), [](uint8_t k) { return k != 0; })) return;
    feature_unknown_index.assign(keep.size(), -1);
    for (size_t f = 0; f < keep.size(); ++f)
      if (keep[f]) feature_unknown_index[f] = num_unknown_poses + num_kept_features++;
  }
  bool IsKept(int32_t feature) const {
    return !feature_unknown_index.empty() && feature_unknown_index[feature] >= 0;
  }

  // For a Problem2d or a Problem3d (core/problem_3d.h).
  template <class Problem>
  static UnknownLayout FromProblem(const Problem& problem) {
    UnknownLayout layout;
    const int32_t n = problem.num_poses();
    std::vector<uint8_t> fixed(problem.pose_fixed.begin(), problem.pose_fixed.end());
    bool any_fixed = false;
    for (uint8_t f : fixed) any_fixed = any_fixed || f != 0;
    if (!any_fixed && problem.gps.empty() && n > 0) fixed[0] = 1;
    layout.anchored_by_gps = !any_fixed && !problem.gps.empty();
    layout.unknown_index.assign(n, -1);
    for (int32_t p = 0; p < n; ++p) {
      if (fixed[p]) {
        ++layout.num_anchored;
      } else {
        layout.unknown_index[p] = layout.num_unknown_poses++;
      }
    }
    return layout;
  }
};

}  // namespace graphslam::core
