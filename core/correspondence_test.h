// The GraphSLAM correspondence test (Thrun & Montemerlo 2006, Table 9 and
// section 6.2): the probability density that two map features m_j and m_k are
// the same physical feature, i.e. that their difference D = m_j - m_k is 0.
//
// With the joint Gaussian of (m_j, m_k) (mean (mu_j, mu_k), covariance
// Sigma_[jk], 4 x 4), D = [I -I] (m_j; m_k) is Gaussian with
//
//   mu_D    = mu_j - mu_k
//   Sigma_D = Sigma_jj + Sigma_kk - Sigma_jk - Sigma_kj
//   pi_{j=k} = N(0; mu_D, Sigma_D) = |2 pi Sigma_D|^{-1/2} exp(-1/2 mu_D^T Sigma_D^{-1} mu_D)
//
// Errata in Table 9 (docs/association.md explains each with a counterexample):
//   l.2: Omega_[j,k] = Omega_jk,jk - Omega_jk,tau Sigma_tau,tau Omega_tau,jk is
//        the marginal information only if Sigma_tau,tau is the pose covariance
//        CONDITIONED on m_j, m_k (the inverse of the reduced matrix built
//        without eliminating j and k); with the path covariance Sigma_0:t of
//        GraphSLAM_solve (which marginalizes them) it is too small and can be
//        indefinite. We use the equivalent moments form (Woodbury):
//          Sigma_[jk] = C^{-1} + C^{-1} B^T Sigma_0:t B C^{-1}
//        (C = Omega_jk,jk block diagonal, B = Omega_tau,jk).
//   l.4-5: the information of a difference is (D Omega^{-1} D^T)^{-1}, not
//        D Omega D^T (independent features with information a and b give
//        ab/(a+b), not a+b); likewise xi_D.
//   l.7: the exponent is -1/2 mu_D^T Omega_D mu_D (Omega_D = Sigma_D^{-1}), not
//        mu_D^T Omega_D^{-1} mu_D.
// pi is a density (units 1/m^2), so the threshold chi of Table 10 depends on
// the map's units; we also return the squared Mahalanobis distance
// mu_D^T Sigma_D^{-1} mu_D, which does not.
//
// Each feature's estimate is a linear function of the reduced system's
// unknowns x (poses, and features that stay unknowns) plus its own noise:
//   eliminated feature (Table 4): m = mu - C^{-1}(g + sum_p H_pm^T dx_p), so
//     m - mu = sum_p Gamma_p^T dx_p + n,  Gamma_p = -H_pm C^{-1} (3 x 2),
//     Cov(n) = C^{-1}, independent of x and of other features' noise;
//   kept feature (an unknown of the reduced system at block b):
//     Gamma_b = [I2; 0], Cov(n) = 0.
// Hence Sigma_jk = delta_jk Cov(n_j) + sum_{p,q} Gamma_jp^T Sigma_pq Gamma_kq,
// which needs only the blocks Sigma_pq of the poses that observe j or k
// (core/pose_marginals.h), never the full inverse.
//
// THREAD SAFETY: pure functions. ALLOCATION: none (fixed-size Eigen).
#pragma once

#include <Eigen/Core>
#include <vector>

namespace graphslam::core {

struct CorrespondenceResult {
  double probability = 0.0;          // pi_{j=k}, density of D at 0 [1/m^2]
  double mahalanobis_squared = 0.0;  // mu_D^T Sigma_D^{-1} mu_D
  bool valid = false;                // false if Sigma_D is not positive definite
};

// Table 9 l.4-7 (corrected) from the joint moments of (m_j, m_k).
CorrespondenceResult CorrespondenceTest(const Eigen::Vector2d& mean_j,
                                        const Eigen::Vector2d& mean_k,
                                        const Eigen::Matrix4d& joint_covariance);

// Table 9 l.4-7 (corrected) from the information form of the joint of
// (m_j, m_k) as l.2-3 define it (Omega_[jk] positive definite, xi = Omega mu).
CorrespondenceResult CorrespondenceTestFromInformation(const Eigen::Matrix4d& information,
                                                       const Eigen::Vector4d& information_vector);

// One feature as a linear function of the reduced unknowns (see above).
struct FeatureGain {
  std::vector<int> blocks;                         // reduced-system blocks, ascending
  std::vector<Eigen::Matrix<double, 3, 2>> gains;  // Gamma per block
  Eigen::Matrix2d own_covariance = Eigen::Matrix2d::Zero();  // Cov(n)
};

}  // namespace graphslam::core
