// Robust kernels for observations: rho(s) applied to the squared Mahalanobis
// error s = e^T W e, so that gross outliers (a misread barcode, a wrong
// association) pull on the map with bounded force.
//
//   none:    rho(s) = s                                     rho'(s) = 1
//   Huber:   rho(s) = s                  if s <= c^2        rho'(s) = 1
//                     2 c sqrt(s) - c^2  otherwise          rho'(s) = c / sqrt(s)
//   Cauchy:  rho(s) = c^2 log(1 + s / c^2)                  rho'(s) = 1 / (1 + s / c^2)
// (Ceres' HuberLoss and CauchyLoss with a = c; g2o's RobustKernelHuber and
// RobustKernelCauchy with delta = c.)
//
// The solver uses iteratively reweighted least squares: each observation's
// information is scaled by rho'(s) at the linearization point and its cost is
// rho(s). The gradient of rho(s) is exactly rho'(s) * 2 J^T W e, so the
// Gauss-Newton model stays first-order exact; the rho'' term is dropped (as
// Ceres does for s where rho'' < 0 would make the model indefinite).
// chi2 reported with a kernel is the robust cost sum rho(s).
//
// THREAD SAFETY: a plain value. ALLOCATION: none.
#pragma once

#include <cmath>
#include <string>
#include <string_view>

#include "core/status.h"

namespace graphslam::core {

struct RobustKernel {
  enum class Type { kNone, kHuber, kCauchy };
  Type type = Type::kNone;
  double scale = 1.0;  // c, in units of standard deviations (s is unitless)

  double Cost(double s) const {
    switch (type) {
      case Type::kNone: return s;
      case Type::kHuber: return s <= scale * scale ? s : 2.0 * scale * std::sqrt(s) - scale * scale;
      case Type::kCauchy: return scale * scale * std::log1p(s / (scale * scale));
    }
    return s;
  }
  double Weight(double s) const {
    switch (type) {
      case Type::kNone: return 1.0;
      case Type::kHuber: return s <= scale * scale ? 1.0 : scale / std::sqrt(s);
      case Type::kCauchy: return 1.0 / (1.0 + s / (scale * scale));
    }
    return 1.0;
  }
};

// Parses "none", "huber[:c]" or "cauchy[:c]" (c > 0, default 1).
StatusOr<RobustKernel> ParseRobustKernel(std::string_view text);
std::string RobustKernelName(const RobustKernel& kernel);

}  // namespace graphslam::core
