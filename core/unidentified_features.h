// Observations that came without a feature id (g2o DATA_FEATURE_POINTXY, native
// log '-', MRCLAM with barcodes ignored): the readers give each one a feature
// of its own whose id is kNoFeatureId. Only data association (solve
// --associate, partition/association/association_driver.h) can use such a problem;
// everything else rejects it, naming the first such observation's line.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <cstdint>

#include "core/problem.h"

namespace graphslam::core {

inline constexpr int64_t kNoFeatureId = -1;

struct UnidentifiedObservations {
  int64_t count = 0;
  int32_t first_line = 0;  // line of the first one in input order (0 if none)
};

inline UnidentifiedObservations CountUnidentifiedObservations(const Problem2d& problem) {
  UnidentifiedObservations out;
  for (const Observation& o : problem.observations) {
    if (problem.feature_ids[o.feature] != kNoFeatureId) continue;
    if (out.count++ == 0) out.first_line = o.line;
  }
  return out;
}

}  // namespace graphslam::core
