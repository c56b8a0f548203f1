#include "core/information_repair.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

namespace graphslam::core {
namespace {

template <int N>
bool Repair(Eigen::Matrix<double, N, N>* information) {
  using Matrix = Eigen::Matrix<double, N, N>;
  const Matrix symmetric = 0.5 * (*information + information->transpose());
  if (symmetric == *information && Eigen::LLT<Matrix>(symmetric).info() == Eigen::Success)
    return false;
  const Eigen::SelfAdjointEigenSolver<Matrix> eigen(symmetric);
  Eigen::Matrix<double, N, 1> values = eigen.eigenvalues();
  const double largest = values.cwiseAbs().maxCoeff();
  const double floor =
      largest > 0.0 ? kInformationEigenvalueFloor * largest : kInformationEigenvalueFloor;
  values = values.cwiseMax(floor);
  *information = eigen.eigenvectors() * values.asDiagonal() * eigen.eigenvectors().transpose();
  // Exactly symmetric (the product rounds the two triangles differently).
  *information = (0.5 * (*information + information->transpose())).eval();
  return true;
}

}  // namespace

bool RepairInformation(double* information) {
  Eigen::Matrix<double, 1, 1> matrix;
  matrix(0, 0) = *information;
  if (!Repair<1>(&matrix)) return false;
  *information = matrix(0, 0);
  return true;
}
bool RepairInformation(Eigen::Matrix2d* information) { return Repair<2>(information); }
bool RepairInformation(Eigen::Matrix3d* information) { return Repair<3>(information); }
bool RepairInformation(Eigen::Matrix<double, 6, 6>* information) {
  return Repair<6>(information);
}

}  // namespace graphslam::core
