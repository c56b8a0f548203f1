// Angle helpers. Every angle residual in graphslam is wrapped to (-pi, pi]
// (docs/design.md), so that a bearing of +179 deg and
// a prediction of -179 deg differ by 2 deg, not 358.
#pragma once

#include <cmath>
#include <numbers>

namespace graphslam::core {

// Returns the angle equal to `angle` modulo 2*pi in (-pi, pi].
inline double WrapAngle(double angle) {
  constexpr double kTwoPi = 2.0 * std::numbers::pi;
  if (angle > -std::numbers::pi && angle <= std::numbers::pi) return angle;
  double wrapped = std::fmod(angle + std::numbers::pi, kTwoPi);
  if (wrapped <= 0.0) wrapped += kTwoPi;
  return wrapped - std::numbers::pi;
}

}  // namespace graphslam::core
