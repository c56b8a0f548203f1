// Ceres residual functors that reproduce g2o's 2-D error functions, so that
// the Ceres peer harness minimizes exactly the chi2 that `graphslam solve`
// minimizes (same residuals, same information matrices, same wrapping).
//
// Each constraint contributes e^T Omega e to chi2 (g2o convention). Ceres
// minimizes 0.5 * sum |r|^2, so every residual is whitened by the upper
// Cholesky factor U of the information matrix (Omega = U^T U):
//   r = U e   =>   |r|^2 = e^T U^T U e = e^T Omega e,   Ceres cost = 0.5 * chi2.
//
// Parameterization: poses are 3 doubles (x, y, theta), landmarks 2 doubles
// (x, y), both updated additively by Ceres (x <- x + delta). Ours steps in the
// body frame (core/se2.h RetractPose); both minimize the same cost, so the
// optimum and its chi2 agree, while the iterates differ.
//
//   EDGE_SE2     (g2o EdgeSE2, core/relative_pose_model.h)
//     e = t2v( Z^{-1} (X_i^{-1} X_j) )
//       e_t  = R(z_th)^T ( R(th_i)^T (t_j - t_i) - z_t )
//       e_th = wrap(th_j - th_i - z_th)                   wrap: [-pi, pi)
//   EDGE_SE2_XY  (g2o EdgeSE2PointXY, core/point_observation_model.h)
//     e = R(th)^T (l - t) - z
//   EDGE_PRIOR_SE2_XY (g2o EdgeSE2XYPrior, core/gps_model.h)
//     e = t - z
// The wrap differs from core::WrapAngle ((-pi, pi]) only at exactly +-pi,
// where e_th^2 is the same.
//
// Templates: Ceres' AutoDiffCostFunction evaluates the functor on Jets, so
// these are header templates by necessity.
//
// THREAD SAFETY: the functors are immutable after construction; Ceres may
// evaluate them concurrently. ALLOCATION: none inside operator().
#pragma once

#include <Eigen/Core>
#include <Eigen/Cholesky>
#include <cmath>
#include <numbers>

namespace graphslam::perf {

// angle - 2 pi floor((angle + pi) / 2 pi): in [-pi, pi), differentiable
// (slope 1) everywhere but at the wrap point. Ceres' pose_graph_2d example
// (normalize_angle.h) uses the same form.
template <typename T>
T WrapAngleTemplated(const T& angle) {
  using std::floor;
  const T two_pi(2.0 * std::numbers::pi);
  return angle - two_pi * floor((angle + T(std::numbers::pi)) / two_pi);
}

// The upper Cholesky factor U of a symmetric positive definite `information`
// (Omega = U^T U). The reader and core::InitializeProblem have already checked
// that the Cholesky factorization succeeds.
template <int kSize>
Eigen::Matrix<double, kSize, kSize> SqrtInformation(
    const Eigen::Matrix<double, kSize, kSize>& information) {
  return information.llt().matrixU();
}

// EDGE_SE2 between pose i (parameter block 0) and pose j (block 1).
class RelativePoseCost {
 public:
  RelativePoseCost(const Eigen::Vector3d& measurement, const Eigen::Matrix3d& information)
      : measurement_(measurement), sqrt_information_(SqrtInformation<3>(information)) {}

  template <typename T>
  bool operator()(const T* const pose_i, const T* const pose_j, T* residual) const {
    using std::cos;
    using std::sin;
    const T dx = pose_j[0] - pose_i[0];
    const T dy = pose_j[1] - pose_i[1];
    const T ci = cos(pose_i[2]), si = sin(pose_i[2]);
    // d = X_i^{-1} X_j, translation part R(th_i)^T (t_j - t_i).
    const T dtx = ci * dx + si * dy;
    const T dty = -si * dx + ci * dy;
    // Z^{-1} d.
    const double cz = std::cos(measurement_.z()), sz = std::sin(measurement_.z());
    const T ux = dtx - T(measurement_.x());
    const T uy = dty - T(measurement_.y());
    Eigen::Matrix<T, 3, 1> error;
    error(0) = T(cz) * ux + T(sz) * uy;
    error(1) = T(-sz) * ux + T(cz) * uy;
    error(2) = WrapAngleTemplated(pose_j[2] - pose_i[2] - T(measurement_.z()));
    Eigen::Map<Eigen::Matrix<T, 3, 1>> whitened(residual);
    whitened = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  Eigen::Vector3d measurement_;
  Eigen::Matrix3d sqrt_information_;
};

// EDGE_SE2_XY: landmark l (parameter block 1) seen from pose (block 0).
class PointObservationCost {
 public:
  PointObservationCost(const Eigen::Vector2d& measurement, const Eigen::Matrix2d& information)
      : measurement_(measurement), sqrt_information_(SqrtInformation<2>(information)) {}

  template <typename T>
  bool operator()(const T* const pose, const T* const landmark, T* residual) const {
    using std::cos;
    using std::sin;
    const T dx = landmark[0] - pose[0];
    const T dy = landmark[1] - pose[1];
    const T c = cos(pose[2]), s = sin(pose[2]);
    Eigen::Matrix<T, 2, 1> error;
    error(0) = c * dx + s * dy - T(measurement_.x());
    error(1) = -s * dx + c * dy - T(measurement_.y());
    Eigen::Map<Eigen::Matrix<T, 2, 1>> whitened(residual);
    whitened = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  Eigen::Vector2d measurement_;
  Eigen::Matrix2d sqrt_information_;
};

// EDGE_PRIOR_SE2_XY: a position fix of one pose (block 0).
class PositionPriorCost {
 public:
  PositionPriorCost(const Eigen::Vector2d& measurement, const Eigen::Matrix2d& information)
      : measurement_(measurement), sqrt_information_(SqrtInformation<2>(information)) {}

  template <typename T>
  bool operator()(const T* const pose, T* residual) const {
    Eigen::Matrix<T, 2, 1> error;
    error(0) = pose[0] - T(measurement_.x());
    error(1) = pose[1] - T(measurement_.y());
    Eigen::Map<Eigen::Matrix<T, 2, 1>> whitened(residual);
    whitened = sqrt_information_.cast<T>() * error;
    return true;
  }

 private:
  Eigen::Vector2d measurement_;
  Eigen::Matrix2d sqrt_information_;
};

}  // namespace graphslam::perf
