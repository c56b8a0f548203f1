// Per-constraint chi2 of a solved problem, by constraint type, for the
// report's residual histograms.
//
// For a constraint with residual e (dimension k) and information W at the
// optimized state, s = e^T W e. If the measurements' noise is Gaussian with
// the covariance W^-1 the input claims, s follows the chi2 distribution with
// k degrees of freedom (a little fewer at the optimum, which absorbed part of
// the noise), with density
//
//   f_k(s) = s^(k/2 - 1) e^(-s/2) / (2^(k/2) Gamma(k/2))
//
// so a histogram far to the right of f_k says the information is too
// optimistic (or there are outliers), far to the left too pessimistic.
// Types: relative-pose odometry (k = 3), velocity motion (3), landmark
// range-bearing and x-y observations (2), GPS (2), robot-to-robot
// range-bearing (2). Observations of excluded features (the solver dropped
// them) and constraints whose residual is undefined (coincident positions)
// are left out.
//
// THREAD SAFETY: pure functions. ALLOCATION: O(constraints).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/problem.h"

namespace graphslam::tools::job {

struct ConstraintChi2 {
  std::string type;  // "odometry", "landmark observation", ...
  int dof = 0;       // k
  std::vector<double> chi2;
};

// One entry per type present in `problem` (none for an empty type).
// `excluded_features` has one flag per feature, or is empty.
std::vector<ConstraintChi2> ConstraintChi2ByType(const core::Problem2d& problem,
                                                 const std::vector<uint8_t>& excluded_features);

// f_k(s) above; 0 for s < 0 (and for s = 0 unless k <= 2).
double Chi2Density(double s, int k);

}  // namespace graphslam::tools::job
