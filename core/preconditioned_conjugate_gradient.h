// Preconditioned conjugate gradients for a symmetric positive definite A:
//
//   solve A x = b,   M^{-1} ~ A^{-1} applied by `preconditioner`
//
//   r = b - A x,  z = M^{-1} r,  p = z
//   repeat:  q = A p,  alpha = (r.z) / (p.q),  x += alpha p,  r -= alpha q,
//            z = M^{-1} r,  beta = (r.z)_new / (r.z)_old,  p = z + beta p
//   until ||r|| <= relative_tolerance * ||b||  or  max_iterations products.
//
// M. R. Hestenes and E. Stiefel, "Methods of conjugate gradients for solving
// linear systems", J. Res. Nat. Bur. Standards 49(6), 1952; preconditioned
// form as in Saad, "Iterative Methods for Sparse Linear Systems", Alg. 9.1.
// The recursively updated residual drifts from b - A x in floating point, so
// every kResidualResetPeriod iterations it is recomputed from scratch (as
// Ceres' ConjugateGradientsSolver does). Breakdown -- p^T A p <= 0 (A not
// positive definite) or r^T M^{-1} r <= 0 (M not positive definite) or a
// non-finite value -- stops the iteration with converged = false and x the
// last finite iterate.
//
// THREAD SAFETY: SolvePcg has no shared state; concurrent calls are fine if
// the operators allow concurrent const products.
//
// ALLOCATION: four scratch vectors of size n are allocated once per call;
// there are no allocations inside the iteration loop.
#pragma once

#include <Eigen/Core>

#include "core/linear_operator.h"
#include "core/status.h"

namespace graphslam::core {

struct PcgOptions {
  int max_iterations = 500;
  double relative_tolerance = 1e-9;  // stop when ||r|| <= tol ||b||

  // InvalidArgument naming the field if max_iterations < 0 or the tolerance
  // is not a positive finite number.
  [[nodiscard]] Status Validate() const;
};

struct PcgSummary {
  int iterations = 0;              // products with A inside the loop
  double relative_residual = 0;    // ||r|| / ||b|| at exit (recursive residual)
  bool converged = false;
};

// Solves a x = b. `x` is the initial guess on input (an empty vector means
// zero) and the solution on output. Requires options.Validate().ok() and
// a.num_rows() == preconditioner.num_rows() == b.size().
PcgSummary SolvePcg(const LinearOperator& a, const LinearOperator& preconditioner,
                    const Eigen::VectorXd& b, const PcgOptions& options, Eigen::VectorXd* x);

}  // namespace graphslam::core
