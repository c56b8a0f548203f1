// Random observations for the scratch-format tests (spill frames, replay
// frames): both kinds, ids and line numbers over the whole int32 range (so
// the delta coding wraps), asymmetric and extreme information entries (a
// denormal, a negative zero), and a bitwise comparison of two observations.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "core/problem.h"

namespace graphslam::testing {

inline std::vector<core::Observation> RandomObservations(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int32_t> index(0, std::numeric_limits<int32_t>::max());
  std::normal_distribution<double> normal(0.0, 1e3);
  std::vector<core::Observation> out(n);
  for (core::Observation& o : out) {
    o.pose = index(rng);
    o.feature = index(rng);
    o.kind = (rng() & 1) ? core::ObservationKind::kPointXY : core::ObservationKind::kRangeBearing;
    o.z = {normal(rng), normal(rng)};
    o.information << normal(rng), normal(rng), normal(rng), normal(rng);
    o.line = index(rng);
  }
  if (n > 0) {
    out[0].information(1) = std::numeric_limits<double>::denorm_min();
    out[0].z(0) = -0.0;
  }
  return out;
}

// Every field equal, the doubles bit for bit (-0.0 and denormals included).
inline void ExpectBitwiseEqual(const core::Observation& a, const core::Observation& b) {
  EXPECT_EQ(a.pose, b.pose);
  EXPECT_EQ(a.feature, b.feature);
  EXPECT_EQ(a.kind, b.kind);
  EXPECT_EQ(std::memcmp(a.z.data(), b.z.data(), sizeof(double) * 2), 0);
  EXPECT_EQ(std::memcmp(a.information.data(), b.information.data(), sizeof(double) * 4), 0);
  EXPECT_EQ(a.line, b.line);
}

}  // namespace graphslam::testing
