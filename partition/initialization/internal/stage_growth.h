// The stage schedule shared by progressive and incremental initialization
// (partition/initialization/progressive_initialization.h, partition/initialization/incremental_initialization.h):
// prefix lengths T_{k+1} = min(N, max(T_k + 1, min(ceil(growth T_k), T_k + A_k))),
// with A_k, the new poses allowed, halved (down to a floor) after an unsettled
// stage and doubled back (up to the cap) after a settled one. A stage is
// unsettled when its iteration cap stopped it while its last iteration still
// lowered chi2 by more than 1 %: its chained segment started too far from the
// optimum for a few iterations.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/graphslam_solver.h"

namespace graphslam::partition::internal {

// T_{k+1} from t = T_k; allowed <= 0 means no cap.
inline int32_t NextStageSize(double growth, int64_t allowed, int32_t t, int32_t n) {
  const double grown = std::ceil(growth * static_cast<double>(t));
  int64_t next = grown >= static_cast<double>(n) ? n : static_cast<int64_t>(grown);
  if (allowed > 0) next = std::min<int64_t>(next, t + allowed);
  return static_cast<int32_t>(std::min<int64_t>(n, std::max<int64_t>(t + 1, next)));
}

// Whether a stage's solve is unsettled (header): not converged, and its last
// iteration still lowered chi2 by more than 1 % of its final chi2.
inline bool IsUnsettled(const core::SolverSummary& stage) {
  const auto& iterations = stage.per_iteration;
  if (stage.converged || iterations.empty()) return false;
  const double last_before =
      iterations.size() == 1 ? stage.initial_chi2 : iterations[iterations.size() - 2].chi2;
  return last_before - stage.final_chi2 > 1e-2 * stage.final_chi2;
}

// A_{k+1} from A_k = allowed and stage k's solve.
inline int64_t NextAllowedNewPoses(const core::SolverSummary& stage, int64_t allowed,
                                   int64_t min_new_poses, int64_t max_new_poses) {
  const int64_t floor = std::min(min_new_poses, max_new_poses);
  return IsUnsettled(stage) ? std::max(floor, allowed / 2) : std::min(max_new_poses, 2 * allowed);
}

}  // namespace graphslam::partition::internal
