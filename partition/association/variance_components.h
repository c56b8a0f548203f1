// Variance components per constraint type at a least-squares solution: one
// a posteriori variance factor for the feature observations, one for the GPS
// fixes and one for the pose constraints (odometry, velocity motion, robot
// range-bearing), so the gates of the incremental pass can scale the
// observations by the factor of the observations alone
// (partition/association/incremental_association.h, docs/association.md).
//
// Why per type: the pooled factor s^2 = chi2 / (m - n)
// (partition/association/internal/variance_factor.h) mixes the groups. On a
// 50 Hz log whose odometry model is wide, the odometry holds most of the
// redundancy and little chi2, so s^2 falls far below 1 although the
// observations' model is right, and scaling the observation gates by it
// rejects their real noise.
//
// Redundancy numbers (Foerstner 1979): for a constraint i with m_i residuals,
// Jacobian A_i (w.r.t. all unknowns) and information Omega_i,
//   r_i = m_i - tr(Omega_i A_i Sigma A_i^T),   sum_i r_i = m - n,
// Sigma the covariance of the unknowns at the solution. Per group
//   s_g^2 = sum_{i in g} chi2_i / sum_{i in g} r_i.
// This is the first step of Foerstner's iteration (weights as stated, one
// solution): exact in expectation when the stated models are right up to a
// common factor; when the groups differ, each estimate is pulled a little
// towards the others (the Helmert cross terms are left out), much less than
// the pooled factor is (the test quantifies it).
//
// How Sigma is reached without inverting (the factor of
// partition/association/feature_covariances.h): an observation of feature j
// from pose p predicts h(x_p, m_j) with m_j - mu_j = Gamma_j^T dx + n_j, so
//   A_i Sigma A_i^T = G_i^T S^{-1} G_i + A_m Cov(n_j) A_m^T,
//   G_i = E_p A_p^T + Gamma_j A_m^T   (reduced unknowns x 2),
// one sparse whitening per observation (PoseMarginals::Whiten), in parallel.
// GPS: G_i = E_p J^T. The exact redundancy is computed for observations and
// fixes; the pose constraints get the rest, (m - n) - r_obs - r_gps, which
// needs no covariance of pose pairs. Observations of features the screening
// excluded (no proper covariance) are left out with their unknowns.
// With a robust kernel on the observations, the solver linearizes with the
// IRLS weights w_i = rho'(e_i^T Omega_i e_i): the observations' group then
// uses w_i Omega_i in chi2 and r_i alike (the factor of the weighted model,
// the one the gate covariances come from). The pose constraints' chi2 is the
// plain one (their kernels, off by default, are not applied).
//
// THREAD SAFETY: const use of the marginals; internally parallel (TBB, one
// whitening workspace per thread), deterministic (summed in order).
// ALLOCATION: O(observations) plus one whitened block per thread at a time.
#pragma once

#include <cstdint>
#include <vector>

#include "core/pose_marginals.h"
#include "core/problem.h"
#include "core/robust_kernel.h"
#include "core/status.h"
#include "partition/association/feature_covariances.h"

namespace graphslam::partition {

struct VarianceComponent {
  int64_t residuals = 0;    // scalar residuals of the group
  double chi2 = 0.0;        // sum e^T Omega e of the group
  double redundancy = 0.0;  // sum of the redundancy numbers r_i
  // chi2 / redundancy, or 1 when the redundancy is below the caller's minimum.
  double factor = 1.0;
};

struct VarianceComponents {
  VarianceComponent observations;
  VarianceComponent gps;
  VarianceComponent pose_constraints;  // odometry, motion, robot range-bearing
};

// The components of `problem` at its current state, from `marginals` and
// `states` as LinearizeAtSolution left them for this problem and state, with
// the observation kernel it used. A group whose redundancy is below
// min_redundancy keeps factor 1.
Status EstimateVarianceComponents(const core::Problem2d& problem,
                                  const core::PoseMarginals& marginals,
                                  const std::vector<FeatureState>& states,
                                  const core::RobustKernel& observation_kernel,
                                  double min_redundancy, VarianceComponents* out);

}  // namespace graphslam::partition
