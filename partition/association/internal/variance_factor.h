// The a posteriori variance factor of a least-squares solution:
//   s^2 = chi2 / r,   r = (residuals) - (unknowns)
// with residuals 2 per observation and GPS fix, 3 per relative pose and
// motion, and unknowns 3 per free pose (less 3 for the gauge when nothing
// holds the frame: no fixed pose, no GPS) and 2 per observed feature. When
// the inputs' noise models are right up to a common scale, s^2 estimates that
// scale (E[chi2] = r at the optimum), and s^2 Sigma is the covariance the data
// support. Victoria Park's models are ~4x too wide in sigma (chi2 389.79 over
// r ~ 7 000), so a gate on the unscaled covariances would accept trees a few
// metres apart as one. Returns 1 when r < min_redundancy (too few residuals
// to say), else s^2 clamped to [1e-4, 1]: never above 1, because wrong
// associations inflate chi2 themselves, and a factor that grew with them
// would widen the gates and hide the wrong merges from the undo test.
//
// THREAD SAFETY: pure function. ALLOCATION: O(features).
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "core/problem.h"

namespace graphslam::partition::internal {

inline double VarianceFactor(const core::Problem2d& problem, double chi2, int64_t min_redundancy) {
  std::vector<uint8_t> observed(problem.features.size(), 0);
  int64_t residuals = 2 * static_cast<int64_t>(problem.observations.size() + problem.gps.size()) +
                      3 * static_cast<int64_t>(problem.relative_poses.size() +
                                               problem.motions.size());
  int64_t unknowns = 0;
  bool anchored = !problem.gps.empty();
  for (uint8_t fixed : problem.pose_fixed) {
    if (fixed) anchored = true;
    else unknowns += 3;
  }
  if (!anchored && unknowns >= 3) unknowns -= 3;
  for (const core::Observation& o : problem.observations) {
    if (o.feature >= 0 && static_cast<size_t>(o.feature) < observed.size() &&
        !observed[o.feature]) {
      observed[o.feature] = 1;
      unknowns += 2;
    }
  }
  const int64_t redundancy = residuals - unknowns;
  if (redundancy < std::max<int64_t>(1, min_redundancy) || !(chi2 >= 0.0)) return 1.0;
  return std::clamp(chi2 / static_cast<double>(redundancy), 1e-4, 1.0);
}

}  // namespace graphslam::partition::internal
