// Linearization of one feature's observations (paper Table 2 l.10-21), in the
// increment form the Schur eliminator consumes.
//
// For each observation o of feature m from pose p (residual e_o, Jacobians
// A_o = de/dx_p (2x3), F_o = de/dm (2x2), information W_o):
//   C    += F^T W F          g_m += F^T W e          (feature block)
//   H_pm += A^T W F                                  (pose-feature coupling)
//   H_pp += A^T W A          g_p += A^T W e          (direct pose terms)
//   chi2 += e^T W e
// With a robust kernel (core/robust_kernel.h) W is scaled by rho'(e^T W e) and
// chi2 accumulates rho(e^T W e) (iteratively reweighted least squares).
// Pose Jacobians are w.r.t. the body-frame increment (core/se2.h).
// Observations from the same pose are summed into one slot. Anchored poses
// contribute to C and g_m only. Damping for Levenberg-Marquardt is added by the
// caller (C + lambda * D_m).
//
// THREAD SAFETY: LinearizeFeature writes only *out. ALLOCATION: reuses out's
// storage; allocates only when a feature has more poses than any before it.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/observation_chunk.h"
#include "core/robust_kernel.h"
#include "core/schur_eliminator.h"
#include "core/unknown_layout.h"

namespace graphslam::core {

struct LinearizedFeature {
  FeatureBlocks blocks;  // C (undamped), g_m, poses (unknown indices), H_pm
  std::vector<Eigen::Matrix3d> pose_hessian;  // direct H_pp per slot of blocks.poses
  std::vector<Eigen::Vector3d> pose_gradient;  // direct g_p per slot
  double chi2 = 0.0;
  int32_t degenerate_observations = 0;  // range-bearing with the feature on the robot
};

void LinearizeFeature(const ObservationChunk& chunk, int64_t feature_slot,
                      const std::vector<Pose2>& poses, const Point2& feature,
                      const UnknownLayout& layout, const RobustKernel& kernel,
                      LinearizedFeature* out);

// chi2 of the feature's observations at (poses, feature), without Jacobians.
double FeatureChi2(const ObservationChunk& chunk, int64_t feature_slot,
                   const std::vector<Pose2>& poses, const Point2& feature,
                   const RobustKernel& kernel);

}  // namespace graphslam::core
