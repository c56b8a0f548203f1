// The chi2 of one observation at a pose and a feature position:
//   e = h(x_p, m) - z (bearing wrapped),   chi2 = e^T Omega e,
// infinity where the model cannot be evaluated (a feature at the sensor).
// Shared by the undo tests of the association rounds and of the incremental
// pass.
//
// THREAD SAFETY: pure function. ALLOCATION: none.
#pragma once

#include <limits>

#include "core/observation_models.h"
#include "core/problem.h"

namespace graphslam::partition::internal {

inline double ObservationChi2(const core::Observation& o, const core::Pose2& pose,
                              const core::Point2& feature) {
  Eigen::Vector2d e;
  if (!core::EvaluateObservation(o.kind, pose, feature, o.z, &e, nullptr, nullptr))
    return std::numeric_limits<double>::infinity();
  return e.dot(o.information * e);
}

}  // namespace graphslam::partition::internal
