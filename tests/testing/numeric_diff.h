// Central-difference Jacobians for checking analytic ones.
//
//   J[:, k] = (f(x + h e_k) - f(x - h e_k)) / (2 h)
// Angle outputs must be wrapped by `f` itself, so differences across +-pi stay
// small; callers pass residual functions that already wrap.
#pragma once

#include <Eigen/Core>
#include <functional>

namespace graphslam::testing {

inline Eigen::MatrixXd NumericJacobian(
    const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& f, const Eigen::VectorXd& x,
    double step = 1e-6) {
  const Eigen::VectorXd f0 = f(x);
  Eigen::MatrixXd jacobian(f0.size(), x.size());
  for (int k = 0; k < x.size(); ++k) {
    Eigen::VectorXd plus = x, minus = x;
    plus[k] += step;
    minus[k] -= step;
    jacobian.col(k) = (f(plus) - f(minus)) / (2.0 * step);
  }
  return jacobian;
}

}  // namespace graphslam::testing
