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
// Kernels are chosen per constraint type (issue 6, item 3): observations
// (feature_linearizer.h) and the pose-only constraints (pose_factors.h):
// relative-pose edges (odometry and loop closures), velocity motion, GPS and
// range-bearing measurements of other robots.
// A wrong loop closure or a GPS multipath fix is the pose-graph analogue of a
// misread barcode. kNone is exactly the plain least-squares term (the solver
// skips the scaling, so results without kernels are bit for bit unchanged).
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

// Kernels of the pose-only constraints (core/pose_factors.h).
struct PoseFactorKernels {
  RobustKernel relative_pose;  // odometry and loop-closure edges
  RobustKernel motion;         // velocity motion (paper Table 2 l.4-9)
  RobustKernel gps;            // GPS position fixes
  RobustKernel robot;          // range-bearing of another robot (pose_range_bearing_model.h)
  bool AllNone() const {
    return relative_pose.type == RobustKernel::Type::kNone &&
           motion.type == RobustKernel::Type::kNone && gps.type == RobustKernel::Type::kNone &&
           robot.type == RobustKernel::Type::kNone;
  }
};

// Parses "none", "huber[:c]" or "cauchy[:c]" (c > 0, default 1).
StatusOr<RobustKernel> ParseRobustKernel(std::string_view text);
std::string RobustKernelName(const RobustKernel& kernel);

// Applies `--robust-kernel` values, separated by spaces, commas or newlines:
// "K" alone (the old form) or "observation=K" sets `*observation`;
// "odometry=K" sets the relative-pose edges and the velocity motion;
// "motion=K" the velocity motion only; "gps=K" the GPS fixes; "robot=K" the
// range-bearing measurements of other robots. Values apply
// left to right, later ones win. On error nothing is changed.
Status ApplyRobustKernelOption(std::string_view text, RobustKernel* observation,
                               PoseFactorKernels* pose_factors);
// "observation=cauchy:1 odometry=huber:1.5 ..." (types with a kernel only;
// "none" when there is none).
std::string RobustKernelsName(const RobustKernel& observation, const PoseFactorKernels& pose);

}  // namespace graphslam::core
