#include "core/correspondence_test.h"

#include <Eigen/Cholesky>
#include <Eigen/LU>
#include <cmath>
#include <numbers>

namespace graphslam::core {

CorrespondenceResult CorrespondenceTest(const Eigen::Vector2d& mean_j,
                                        const Eigen::Vector2d& mean_k,
                                        const Eigen::Matrix4d& joint_covariance) {
  CorrespondenceResult result;
  const Eigen::Vector2d mean = mean_j - mean_k;
  Eigen::Matrix2d covariance = joint_covariance.topLeftCorner<2, 2>() +
                               joint_covariance.bottomRightCorner<2, 2>() -
                               joint_covariance.topRightCorner<2, 2>() -
                               joint_covariance.bottomLeftCorner<2, 2>();
  covariance = 0.5 * (covariance + covariance.transpose()).eval();
  const Eigen::LLT<Eigen::Matrix2d> llt(covariance);
  if (llt.info() != Eigen::Success || !(covariance.determinant() > 0.0) ||
      !std::isfinite(covariance.determinant())) {
    return result;
  }
  result.mahalanobis_squared = mean.dot(llt.solve(mean));
  const double determinant = (2.0 * std::numbers::pi * covariance).determinant();
  result.probability = std::exp(-0.5 * result.mahalanobis_squared) / std::sqrt(determinant);
  result.valid = std::isfinite(result.probability);
  return result;
}

CorrespondenceResult CorrespondenceTestFromInformation(const Eigen::Matrix4d& information,
                                                       const Eigen::Vector4d& information_vector) {
  const Eigen::LLT<Eigen::Matrix4d> llt(information);
  if (llt.info() != Eigen::Success) return CorrespondenceResult();
  const Eigen::Matrix4d covariance = llt.solve(Eigen::Matrix4d::Identity());
  const Eigen::Vector4d mean = llt.solve(information_vector);
  return CorrespondenceTest(mean.head<2>(), mean.tail<2>(), covariance);
}

}  // namespace graphslam::core
