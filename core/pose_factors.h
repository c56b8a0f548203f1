// Linearization of the pose-only constraints, for both spaces
// (core/problem_space.h):
//   - planar (Problem2d, core/pose_factors.cc): relative-pose odometry,
//     velocity motion, GPS (paper Table 2 l.4-9 for motion; eq. 3 for GPS) and
//     range-bearing measurements of one pose from another (robot to robot,
//     core/pose_range_bearing_model.h), or of a position interpolated
//     between two poses (core/interpolated_pose_range_bearing_model.h);
//   - 3-D (Problem3d, core/pose_factors_3d.cc): relative poses
//     (core/relative_pose_3d_model.h) and GPS positions (core/gps_3d_model.h).
//
// For each constraint with residual e(x) (Jacobians A_k w.r.t. the body-frame
// increments d of the poses it touches: x (+) d) and information W, in
// increment form about the current estimate:
//   H_kl += A_k^T W A_l      (information matrix, pose blocks)
//   g_k  += A_k^T W e        (gradient; the system solved is H dx = -g)
//   chi2 += e^T W e          (g2o convention)
// Blocks of anchored poses are dropped (UnknownLayout).
//
// Robust kernels per constraint type (core/robust_kernel.h), by IRLS: with
// s = e^T W e, W is replaced by rho'(s) W in H and g, and chi2 adds rho(s).
// The gradient rho'(s) J^T W e is then exact; rho'' is dropped. With kNone
// nothing is scaled (bit-for-bit the plain least-squares sums). A kernel of a
// type the space has no constraint of (3-D: motion, robot) is unused.
//
// The three functions are templates on the problem type, defined once in
// core/internal/pose_factor_sums.h and instantiated for Problem2d and
// Problem3d only.
//
// THREAD SAFETY: pure functions of their inputs; outputs are caller-owned.
// ALLOCATION: none beyond the caller's outputs.
#pragma once

#include <Eigen/Core>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/robust_kernel.h"
#include "core/unknown_layout.h"

namespace graphslam::core {

// chi2 (robust cost with kernels) of all pose-only constraints at `poses`.
template <class Problem>
double PoseFactorsChi2(const Problem& problem, const std::vector<typename Problem::Pose>& poses,
                       const PoseFactorKernels& kernels = PoseFactorKernels());

// Adds H and g of all pose-only constraints (at `poses`) into `hessian`
// (pattern must contain their pairs), `gradient` and `hessian_diagonal` (pose
// dimension entries per unknown pose). Returns their chi2 (robust cost).
template <class Problem>
double LinearizePoseFactors(const Problem& problem,
                            const std::vector<typename Problem::Pose>& poses,
                            const UnknownLayout& layout, BlockSparseMatrix* hessian,
                            Eigen::VectorXd* gradient, Eigen::VectorXd* hessian_diagonal,
                            const PoseFactorKernels& kernels = PoseFactorKernels());

// The unknown-pose pairs the pose-only constraints couple (for the pattern).
template <class Problem>
void AppendPoseFactorPattern(const Problem& problem, const UnknownLayout& layout,
                             std::vector<std::pair<int, int>>* pairs);

}  // namespace graphslam::core
