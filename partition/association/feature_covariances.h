// Feature covariances at a solution, for the correspondence tests
// (docs/association.md, "Covariances without the full inverse").
//
// LinearizeAtSolution builds the reduced system S at the problem's current
// state (lambda = 0), factorizes it (core/pose_marginals.h) and gives every
// feature its gain: m - mu = sum_p Gamma_p^T dx_p + n, Cov(n) = C^{-1} for an
// eliminated feature (Gamma_p = -H_pm C^{-1}), a selector of its block and no
// own noise for a kept one. Then
//   Sigma_jk = delta_jk Cov(n_j) + y_j^T y_k,   y_j = L^{-1} P Gamma_j,
// and WhitenFeatures computes y_j (one sparse forward solve per feature, in
// parallel) plus Sigma_jj, so any pair costs one sparse dot product.
//
// THREAD SAFETY: one call at a time per PoseMarginals; WhitenFeatures is
// internally parallel (TBB, one workspace per thread). ALLOCATION: the
// factor, one gain per feature, one whitened column block per requested
// feature (its elimination-tree reach).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "core/chunk_source.h"
#include "core/correspondence_test.h"
#include "core/graphslam_solver.h"
#include "core/pose_marginals.h"
#include "core/problem.h"
#include "core/status.h"

namespace graphslam::partition {

// What the tests need of one feature at the current solution.
struct FeatureState {
  core::FeatureGain gain;
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();  // C (weights merged positions)
  bool usable = false;  // positive definite and observed
};

// The reduced system S at the solution (lambda = 0), factorized into
// *marginals, and every feature's gain (states->size() == num_features).
Status LinearizeAtSolution(const core::SolverOptions& solver_options,
                           const core::ChunkSource& chunks, const core::Problem2d& problem,
                           core::PoseMarginals* marginals, std::vector<FeatureState>* states);

// Whitened gains of `features` (all usable) and their marginal covariances
// Sigma_jj = Cov(n_j) + y_j^T y_j, in the order given.
struct WhitenedFeatures {
  std::vector<core::PoseMarginals::WhitenedColumns> whitened;
  std::vector<Eigen::Matrix2d> covariance;  // Sigma_jj
};
Status WhitenFeatures(const core::PoseMarginals& marginals, const std::vector<FeatureState>& states,
                      const std::vector<int32_t>& features, WhitenedFeatures* out);

}  // namespace graphslam::partition
