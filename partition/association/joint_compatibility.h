// AssignScanJointly: the observations of one scan (one pose) paired with map
// features by joint compatibility branch and bound (JCBB; Neira and Tardos,
// "Data association in stochastic mapping using the joint compatibility
// test", IEEE T-RA 2001).
//
// Points: the n observations' feature estimates o_0..o_{n-1} (placed from the
// scan's pose) and m target features t_0..t_{m-1}, with means and one dense
// joint covariance S of all n + m points (2 (n + m) square): the estimates of
// one scan are correlated through its pose, and the targets with them
// through the map. A hypothesis H pairs some observations i with distinct
// targets a_i (the others become new features). Its differences
// D_i = o_i - t_{a_i} are jointly Gaussian with
//   mu_D   = (mu_{o_i} - mu_{t_{a_i}})_i
//   Cov(D_i, D_j) = S(o_i, o_j) - S(o_i, t_{a_j}) - S(t_{a_i}, o_j) + S(t_{a_i}, t_{a_j}),
// and H is jointly compatible when
//   D^2(H) = mu_D^T Cov(D)^{-1} mu_D <= chi2^{-1}(2 |H|)   (quantile at normal z).
// A pair is individually compatible when its own D^2 is below chi2^{-1}(2).
//
// The search goes through the observations in order; each either takes an
// individually compatible target not yet used, the extension staying jointly
// compatible, or none. Answer: among the hypotheses built that way (every
// prefix jointly compatible), the one with the most pairings, ties broken by
// the smallest D^2. Exact: a branch is cut only when even pairing every
// remaining observation cannot beat the best pairing count, or when it cannot
// beat it (equal count) and its D^2 already is no smaller (D^2 never
// decreases when a pair is added: the Mahalanobis distance of a marginal is
// at most that of the joint). tests/partition/association/joint_compatibility_test.cc
// checks it against enumerating every hypothesis.
//
// Two observations of one scan never get one target (exclusivity): one scan
// does not see one landmark twice.
//
// THREAD SAFETY: a pure function. ALLOCATION: O((n + m)^2) plus one
// hypothesis-sized Cholesky per visited node.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace graphslam::partition {

// Normal z of the association gates (JCBB here, the undo tests of the
// incremental pass and of the rounds): p = Phi(z) = 0.999146, where the
// exact 2-dof quantile is 14.131. The pass's other defaults (stages,
// windows, loop closure, variance scaling) were chosen with a 2-dof gate of
// 14.131, and the real-data figures depend on it (docs/association.md,
// "Gate quantiles"): it is a chosen gate, not the nominal 0.999 (13.816).
inline constexpr double kDefaultGateZ = 3.1368;

struct JointCompatibilityOptions {
  double z = kDefaultGateZ;    // normal quantile of the gates (p = 0.999146)
  int64_t max_nodes = 200000;  // search nodes before settling for the best found
};

struct ScanAssociationInput {
  int observations = 0;                 // n
  int targets = 0;                      // m
  std::vector<Eigen::Vector2d> means;   // n observations, then m targets
  Eigen::MatrixXd covariance;           // 2 (n + m) square, same order
};

struct ScanAssignment {
  std::vector<int32_t> target;  // per observation: target index, or -1 (new feature)
  int pairings = 0;
  double mahalanobis_squared = 0.0;  // D^2 of the chosen hypothesis
  int64_t nodes = 0;
  bool exhausted = false;  // max_nodes reached: best found, not proven best
};

ScanAssignment AssignScanJointly(const ScanAssociationInput& input,
                                 const JointCompatibilityOptions& options);

// D^2 of a hypothesis (target[i] = -1: unpaired); +infinity if its
// covariance is not positive definite. Exposed for the tests.
double JointMahalanobisSquared(const ScanAssociationInput& input,
                               const std::vector<int32_t>& target);

}  // namespace graphslam::partition
