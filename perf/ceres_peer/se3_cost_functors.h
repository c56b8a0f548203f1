// Ceres residuals for the 3-D g2o edges, written from g2o's definitions and
// independent of core/ (no shared SE(3) code with the solver under test):
//
//   EDGE_SE3:QUAT i j z:   E = Z^-1 (X_i^-1 X_j),  e = [t_E; vec(q_E)] with
//                          q_E taken with w >= 0 (g2o EdgeSE3, toVectorMQT)
//   EDGE_SE3_TRACKXYZ i l: e = R_i^T (m_l - t_i) - z
//   EDGE_SE3_XYZPRIOR i:   e = t_i - z
//
// residual = U e with Omega = U^T U, so |residual|^2 = e^T Omega e (g2o's chi2).
// A pose is two parameter blocks: t (3) and q (4, Eigen's x y z w order, on
// ceres::EigenQuaternionManifold).
//
// THREAD SAFETY: immutable after construction. ALLOCATION: none in operator().
#pragma once

#include <ceres/rotation.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <Eigen/Geometry>

namespace graphslam::perf {

template <int kSize>
Eigen::Matrix<double, kSize, kSize> UpperSqrt(const Eigen::Matrix<double, kSize, kSize>& omega) {
  return omega.llt().matrixU();
}

class RelativePose3Cost {
 public:
  RelativePose3Cost(const Eigen::Vector3d& t, const Eigen::Quaterniond& q,
                    const Eigen::Matrix<double, 6, 6>& information)
      : z_t_(t), z_q_(q), sqrt_information_(UpperSqrt<6>(information)) {}

  template <typename T>
  bool operator()(const T* const ti, const T* const qi, const T* const tj, const T* const qj,
                  T* residual) const {
    using Quaternion = Eigen::Quaternion<T>;
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Vector3> t_i(ti), t_j(tj);
    const Eigen::Map<const Quaternion> q_i(qi), q_j(qj);
    // D = X_i^-1 X_j.
    const Quaternion q_i_inv = q_i.conjugate();
    const Quaternion q_d = q_i_inv * q_j;
    const Vector3 t_d = q_i_inv * (t_j - t_i);
    // E = Z^-1 D.
    const Quaternion z_inv = z_q_.conjugate().cast<T>();
    Quaternion q_e = z_inv * q_d;
    const Vector3 t_e = z_inv * (t_d - z_t_.cast<T>());
    q_e.normalize();
    if (q_e.w() < T(0)) q_e.coeffs() = -q_e.coeffs();
    Eigen::Matrix<T, 6, 1> e;
    e << t_e, q_e.vec();
    Eigen::Map<Eigen::Matrix<T, 6, 1>> r(residual);
    r = sqrt_information_.cast<T>() * e;
    return true;
  }

 private:
  Eigen::Vector3d z_t_;
  Eigen::Quaterniond z_q_;
  Eigen::Matrix<double, 6, 6> sqrt_information_;
};

class PointInPoseCost {
 public:
  PointInPoseCost(const Eigen::Vector3d& z, const Eigen::Matrix3d& information)
      : z_(z), sqrt_information_(UpperSqrt<3>(information)) {}

  template <typename T>
  bool operator()(const T* const t, const T* const q, const T* const m, T* residual) const {
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    const Eigen::Map<const Eigen::Quaternion<T>> q_i(q);
    const Vector3 local = q_i.conjugate() * (Eigen::Map<const Vector3>(m) -
                                             Eigen::Map<const Vector3>(t));
    Eigen::Map<Vector3> r(residual);
    r = sqrt_information_.cast<T>() * (local - z_.cast<T>());
    return true;
  }

 private:
  Eigen::Vector3d z_;
  Eigen::Matrix3d sqrt_information_;
};

class PositionPrior3Cost {
 public:
  PositionPrior3Cost(const Eigen::Vector3d& z, const Eigen::Matrix3d& information)
      : z_(z), sqrt_information_(UpperSqrt<3>(information)) {}

  template <typename T>
  bool operator()(const T* const t, T* residual) const {
    using Vector3 = Eigen::Matrix<T, 3, 1>;
    Eigen::Map<Vector3> r(residual);
    r = sqrt_information_.cast<T>() * (Eigen::Map<const Vector3>(t) - z_.cast<T>());
    return true;
  }

 private:
  Eigen::Vector3d z_;
  Eigen::Matrix3d sqrt_information_;
};

}  // namespace graphslam::perf
