// Linearization of the pose-only constraints of a 3-D problem: relative poses
// (core/relative_pose3_model.h) and GPS positions (core/gps3_model.h); the 3-D
// overloads of core/pose_factors.h, called by the one solver loop of both
// spaces (core/internal/chunked_solve.h).
//
// For each constraint with residual e(x) (Jacobians A_k w.r.t. the body-frame
// increments d of the poses it touches, x Exp(d)) and information W:
//   H_kl += A_k^T W A_l      (6 x 6 pose blocks)
//   g_k  += A_k^T W e
//   chi2 += e^T W e
// Blocks of anchored poses are dropped (UnknownLayout). Robust kernels
// (core/robust_kernel.h, pose_kernels.relative_pose / .gps) by IRLS: W is
// replaced by rho'(s) W and chi2 adds rho(s), s = e^T W e; kNone scales
// nothing. (pose_kernels.motion has no 3-D constraint.)
//
// THREAD SAFETY: pure functions of their inputs; outputs are caller-owned.
// ALLOCATION: none beyond the caller's outputs.
#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/problem_3d.h"
#include "core/robust_kernel.h"
#include "core/unknown_layout.h"

namespace graphslam::core {

// chi2 (robust cost with kernels) of all pose-only constraints at `poses`.
double PoseFactorsChi2(const Problem3d& problem, const std::vector<Pose3>& poses,
                       const PoseFactorKernels& kernels = PoseFactorKernels());

// Adds H and g of all pose-only constraints (at `poses`) into `hessian`
// (pattern must contain their pairs), `gradient` and `hessian_diagonal` (6 per
// unknown pose). Returns their chi2 (robust cost).
double LinearizePoseFactors(const Problem3d& problem, const std::vector<Pose3>& poses,
                            const UnknownLayout& layout, BlockSparseMatrix* hessian,
                            Eigen::VectorXd* gradient, Eigen::VectorXd* hessian_diagonal,
                            const PoseFactorKernels& kernels = PoseFactorKernels());

// The unknown-pose pairs the relative poses couple (for the pattern).
void AppendPoseFactorPattern(const Problem3d& problem, const UnknownLayout& layout,
                             std::vector<std::pair<int, int>>* pairs);

}  // namespace graphslam::core
