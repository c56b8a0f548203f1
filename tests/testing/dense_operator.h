// The dense matrix of a linear operator, one column per unit vector:
// column c = M e_c. For comparing a preconditioner's M^-1 (or any operator
// given only by its product) with dense reference math.
#pragma once

#include <Eigen/Dense>

#include "core/linear_operator.h"

namespace graphslam::testing {

inline Eigen::MatrixXd DenseMatrixOf(const core::LinearOperator& m) {
  const int n = m.num_rows();
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd unit = Eigen::VectorXd::Zero(n);
  for (int c = 0; c < n; ++c) {
    unit[c] = 1.0;
    m.RightMultiplyAndAccumulate(unit.data(), dense.col(c).data());
    unit[c] = 0.0;
  }
  return dense;
}

}  // namespace graphslam::testing
