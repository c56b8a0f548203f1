// Preconditioned conjugate gradients for a symmetric positive definite A:
//
//   solve A x = b,   M^{-1} ~ A^{-1} applied by `preconditioner`
//
//   r = b - A x,  z = M^{-1} r,  p = z
//   repeat:  q = A p,  alpha = (r.z) / (p.q),  x += alpha p,  r -= alpha q,
//            z = M^{-1} r,  beta = (r.z)_new / (r.z)_old,  p = z + beta p
//   until ||r|| <= relative_tolerance * ||b||  or  max_iterations products
//   or (energy_tolerance > 0, i >= 10)  i g_i <= energy_tolerance  and
//        i g_i <= (g_1 + ... + g_i) / 2  and  (r.z)_{i+1} <= energy_tolerance,
//        g_i = alpha_i (r.z)_i.
//
// The energy test (truncated Newton after Nash & Sofer, "Assessing a search
// direction within a truncated-Newton method", Oper. Res. Lett. 9, 1990).
// Each iteration lowers the A-norm error by exactly its alpha (r.z) (r is
// orthogonal to the previous direction, so p.r = z.r):
//   |x_i - x*|_A^2 - |x_{i+1} - x*|_A^2 = alpha_i (r.z)_i,
// and |x_i - x*|_A^2 = sum_{j>=i} alpha_j (r.z)_j is what the quadratic model
// q(x) = x^T A x / 2 - b^T x still has to gain, times 2. The sum is unknown
// before the later iterations run; i alpha_i (r.z)_i (the last gain times the
// iterations so far) estimates it: it is conservative while CG converges
// faster than 1/i per iteration and grows with the count when it stalls.
// It is not conservative when the first gains are small because the error
// lies in modes the first Krylov vectors hardly see (a warm start that has
// already taken the easy part), hence the second condition, Nash & Sofer's
// own relative test with c = 1/2: the gains must have started to fall faster
// than 1/i, which a plateau of small gains does not. Nor is it enough on pose
// graphs with loop closures, hence the third: r^T M^{-1} r, the M^{-1}-norm
// of the residual, equals |x - x*|_A^2 = r^T A^{-1} r where M matches A and bounds
// it from above where M <= A; it sees the slow modes the gains miss. And
// none of the three is reliable in the first iterations after a warm start,
// so the test waits for 10 iterations: the late, expensive solves it is for
// take hundreds (the cases behind each condition: docs/tuning.md).
// A Newton-type caller sets energy_tolerance to the objective decrease below
// which a better step makes no difference to it (core/reduced_system_solver.h).
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
  // Stop when the estimated |x - x*|_A^2 (above) is at most this; 0: off.
  double energy_tolerance = 0.0;

  // InvalidArgument naming the field if max_iterations < 0, the tolerance
  // is not a positive finite number or energy_tolerance not finite >= 0.
  [[nodiscard]] Status Validate() const;
};

struct PcgSummary {
  int iterations = 0;              // products with A inside the loop
  double relative_residual = 0;    // ||r|| / ||b|| at exit (recursive residual)
  bool converged = false;
  bool truncated = false;          // stopped by the energy test (converged is false)
};

// Solves a x = b. `x` is the initial guess on input (an empty vector means
// zero) and the solution on output. Requires options.Validate().ok() and
// a.num_rows() == preconditioner.num_rows() == b.size().
PcgSummary SolvePcg(const LinearOperator& a, const LinearOperator& preconditioner,
                    const Eigen::VectorXd& b, const PcgOptions& options, Eigen::VectorXd* x);

}  // namespace graphslam::core
