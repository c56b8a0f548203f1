// Linearization of the pose-only constraints: relative-pose odometry, velocity
// motion, GPS (paper Table 2 l.4-9 for motion; eq. 3 for GPS) and
// range-bearing measurements of one pose from another (robot to robot,
// core/pose_range_bearing_model.h).
//
// For each constraint with residual e(x) (Jacobians A_k w.r.t. the poses it
// touches) and information W, in increment form about the current estimate:
//   H_kl += A_k^T W A_l      (information matrix, pose blocks)
//   g_k  += A_k^T W e        (gradient; the system solved is H dx = -g)
//   chi2 += e^T W e          (g2o convention)
// Blocks of anchored poses are dropped (UnknownLayout).
//
// Robust kernels per constraint type (core/robust_kernel.h), by IRLS: with
// s = e^T W e, W is replaced by rho'(s) W in H and g, and chi2 adds rho(s).
// The gradient rho'(s) J^T W e is then exact; rho'' is dropped. With kNone
// nothing is scaled (bit-for-bit the plain least-squares sums).
//
// THREAD SAFETY: pure functions of their inputs; outputs are caller-owned.
// ALLOCATION: none beyond the caller's outputs.
#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/problem.h"
#include "core/robust_kernel.h"
#include "core/unknown_layout.h"

namespace graphslam::core {

// chi2 (robust cost with kernels) of all pose-only constraints at `poses`.
double PoseFactorsChi2(const Problem2d& problem, const std::vector<Pose2>& poses,
                       const PoseFactorKernels& kernels = PoseFactorKernels());

// Adds H and g of all pose-only constraints (at `poses`) into `hessian`
// (pattern must contain their pairs), `gradient` (3 per unknown pose) and
// `hessian_diagonal` (3 per unknown pose). Returns their chi2 (robust cost).
double LinearizePoseFactors(const Problem2d& problem, const std::vector<Pose2>& poses,
                            const UnknownLayout& layout, BlockSparseMatrix* hessian,
                            Eigen::VectorXd* gradient, Eigen::VectorXd* hessian_diagonal,
                            const PoseFactorKernels& kernels = PoseFactorKernels());

// The unknown-pose pairs the pose-only constraints couple (for the pattern).
void AppendPoseFactorPattern(const Problem2d& problem, const UnknownLayout& layout,
                             std::vector<std::pair<int, int>>* pairs);

}  // namespace graphslam::core
