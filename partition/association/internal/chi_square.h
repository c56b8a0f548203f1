// Chi-square quantiles for the association gates.
//
// Two degrees of freedom (one planar point difference) have the closed form
//   F^{-1}(p; 2) = -2 ln(1 - p);
// any other count uses Wilson and Hilferty's cube-root normal approximation
//   F^{-1}(p; k) ~= k (1 - 2/(9k) + z sqrt(2/(9k)))^3,  z = Phi^{-1}(p),
// which is within 1 % of the exact quantile for k >= 2 at z = 3.09.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <cmath>

namespace graphslam::partition::internal {

// Quantile for `dof` degrees of freedom at standard normal z (Wilson-Hilferty).
inline double ChiSquareQuantile(double dof, double z) {
  const double a = 2.0 / (9.0 * dof);
  const double c = 1.0 - a + z * std::sqrt(a);
  return dof * c * c * c;
}

}  // namespace graphslam::partition::internal
