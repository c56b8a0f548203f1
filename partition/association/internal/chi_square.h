// Chi-square quantiles for the association gates.
//
// A gate at standard normal z accepts a squared Mahalanobis distance d^2 with
// k degrees of freedom when
//   d^2 <= F^{-1}(p; k),   p = Phi(z)   (z = 3.0902: p = 0.999),
// F the chi-square distribution function and Phi the standard normal one.
// Both come from Boost.Math, exact to double precision: F^{-1}(p; k) =
// 2 P^{-1}(k/2, p), P^{-1} the inverse of the regularized lower incomplete
// gamma function. For k = 2 (one planar point difference) this is
// -2 ln(1 - p) (13.8155 at p = 0.999). The tail 1 - p = Phi(-z) is what
// Boost inverts, so z far in the tail keeps its precision; a z whose tail
// underflows (z > ~38) gives +infinity, a NaN z gives NaN (every comparison
// with it false): values, not exceptions.
//
// THREAD SAFETY: pure functions. ALLOCATION: none.
#pragma once

#include <boost/math/distributions/chi_squared.hpp>
#include <boost/math/distributions/normal.hpp>
#include <boost/math/policies/policy.hpp>

#include "core/check.h"

namespace graphslam::partition::internal {

// Errors as values: a domain error (NaN z) gives NaN, an overflow (the tail
// probability 0) +infinity.
using ChiSquarePolicy = boost::math::policies::policy<
    boost::math::policies::domain_error<boost::math::policies::ignore_error>,
    boost::math::policies::overflow_error<boost::math::policies::ignore_error>>;

// F^{-1}(Phi(z); dof) for dof > 0.
inline double ChiSquareQuantile(double dof, double z) {
  GS_CHECK(dof > 0.0);
  const boost::math::normal_distribution<double, ChiSquarePolicy> normal;
  const boost::math::chi_squared_distribution<double, ChiSquarePolicy> chi_squared(dof);
  const double tail = boost::math::cdf(boost::math::complement(normal, z));
  return boost::math::quantile(boost::math::complement(chi_squared, tail));
}

}  // namespace graphslam::partition::internal
