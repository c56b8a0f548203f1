#include "core/preconditioned_conjugate_gradient.h"

#include <cmath>
#include <fmt/format.h>

#include "core/check.h"

namespace graphslam::core {
namespace {

// Recompute r = b - A x every this many iterations (one extra product).
constexpr int kResidualResetPeriod = 50;
// The energy test applies from this many iterations on (header).
constexpr int kMinTruncatedIterations = 10;

}  // namespace

Status PcgOptions::Validate() const {
  if (max_iterations < 0) {
    return Status::InvalidArgument(
        fmt::format("PcgOptions.max_iterations must be >= 0, got {}", max_iterations));
  }
  if (!(relative_tolerance > 0.0) || !std::isfinite(relative_tolerance)) {
    return Status::InvalidArgument(fmt::format(
        "PcgOptions.relative_tolerance must be positive and finite, got {:g}",
        relative_tolerance));
  }
  if (!(energy_tolerance >= 0.0) || !std::isfinite(energy_tolerance)) {
    return Status::InvalidArgument(fmt::format(
        "PcgOptions.energy_tolerance must be finite and >= 0, got {:g}", energy_tolerance));
  }
  return Status::Ok();
}

PcgSummary SolvePcg(const LinearOperator& a, const LinearOperator& preconditioner,
                    const Eigen::VectorXd& b, const PcgOptions& options, Eigen::VectorXd* x) {
  GS_CHECK(options.Validate().ok());
  const Eigen::Index n = b.size();
  GS_CHECK(a.num_rows() == n && preconditioner.num_rows() == n);
  if (x->size() == 0) x->setZero(n);
  GS_CHECK(x->size() == n);

  PcgSummary summary;
  const double norm_b = b.norm();
  if (norm_b == 0.0) {
    x->setZero();
    summary.converged = true;
    return summary;
  }
  const double tolerance = options.relative_tolerance * norm_b;

  // The only allocations of the solve.
  Eigen::VectorXd r(n), z(n), p(n), q(n);

  r = b;
  q.setZero();
  a.RightMultiplyAndAccumulate(x->data(), q.data());
  r -= q;
  double norm_r = r.norm();
  double rho_old = 1.0;
  double gain = 0.0;           // sum of alpha_i (r.z)_i, the energy test's reference
  double last_estimate = -1.0; // i alpha_i (r.z)_i of the last iteration (-1: none yet)
  for (;;) {
    summary.relative_residual = norm_r / norm_b;
    if (!std::isfinite(norm_r)) break;
    if (norm_r <= tolerance) {
      summary.converged = true;
      break;
    }
    if (summary.iterations >= options.max_iterations) break;

    z.setZero();
    preconditioner.RightMultiplyAndAccumulate(r.data(), z.data());
    const double rho = r.dot(z);
    if (!(rho > 0.0) || !std::isfinite(rho)) break;  // M^{-1} not positive definite
    // The energy test of the header (after the residual's: a solve that
    // meets both reports converged).
    if (options.energy_tolerance > 0.0 && summary.iterations >= kMinTruncatedIterations &&
        last_estimate <= options.energy_tolerance && last_estimate <= 0.5 * gain &&
        rho <= options.energy_tolerance) {
      summary.truncated = true;
      break;
    }
    if (summary.iterations == 0) {
      p = z;
    } else {
      p = z + (rho / rho_old) * p;
    }
    q.setZero();
    a.RightMultiplyAndAccumulate(p.data(), q.data());
    const double p_a_p = p.dot(q);
    if (!(p_a_p > 0.0) || !std::isfinite(p_a_p)) break;  // A not positive definite
    const double alpha = rho / p_a_p;
    *x += alpha * p;
    ++summary.iterations;
    if (summary.iterations % kResidualResetPeriod == 0) {
      r = b;
      q.setZero();
      a.RightMultiplyAndAccumulate(x->data(), q.data());
      r -= q;
    } else {
      r -= alpha * q;
    }
    rho_old = rho;
    norm_r = r.norm();
    gain += alpha * rho;
    last_estimate = summary.iterations * alpha * rho;
  }
  return summary;
}

}  // namespace graphslam::core
