// RobustTerm: one constraint's contribution under a robust kernel rho, shared
// by the 2-D and 3-D pose factors (core/internal/pose_factor_sums.h).
//
//   s = e^T W e;   cost = rho(s);   linearization information = rho'(s) W
//
// (IRLS, as Ceres' LossFunction with its first-order correction omitted.)
// kNone returns s and W untouched, so plain least squares does no multiply
// by 1.0 and stays bit-identical to the kernel-free code.
//
// THREAD SAFETY: a pure function. ALLOCATION: none.
#pragma once

#include <Eigen/Core>

#include "core/robust_kernel.h"

namespace graphslam::core::internal {

// Returns rho(e^T W e); writes rho'(e^T W e) W into *weighted when non-null.
template <int kResidual>
double RobustTerm(const RobustKernel& kernel, const Eigen::Matrix<double, kResidual, 1>& residual,
                  const Eigen::Matrix<double, kResidual, kResidual>& information,
                  Eigen::Matrix<double, kResidual, kResidual>* weighted) {
  const double squared = residual.dot(information * residual);
  if (kernel.type == RobustKernel::Type::kNone) {
    if (weighted != nullptr) *weighted = information;
    return squared;
  }
  if (weighted != nullptr) *weighted = kernel.Weight(squared) * information;
  return kernel.Cost(squared);
}

}  // namespace graphslam::core::internal
