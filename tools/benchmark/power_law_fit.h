// PowerLawFit: y ≈ c · x^k by least squares on the logarithms,
//
//   log y_i = log c + k · log x_i,   minimize Σ (log y_i − log c − k log x_i)^2
//
// so k is the slope of the log-log line through the points: 1 means linear
// growth, 2 quadratic. Points with x <= 0 or y <= 0 (or not finite) are
// skipped. With fewer than two distinct x the fit is undefined (`valid` false).
//
// THREAD SAFETY: pure function. ALLOCATION: none.
#pragma once

#include <vector>

namespace graphslam::tools::benchmark {

struct PowerLaw {
  bool valid = false;
  double exponent = 0.0;     // k
  double coefficient = 0.0;  // c
  int points = 0;            // points used
};

PowerLaw FitPowerLaw(const std::vector<double>& x, const std::vector<double>& y);

}  // namespace graphslam::tools::benchmark
