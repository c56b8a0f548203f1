// SolveGraphSlam3d: the GraphSLAM loop (paper Table 5) on 3-D problems, with
// the same Levenberg-Marquardt control, reduce / solve / recover structure and
// linear algebra as the planar SolveGraphSlam (core/graphslam_solver.h):
//
//   1. linearize every constraint about (x, m) against the retraction
//      x (+) d = x Exp(d) (core/se3_lie.h) and eliminate every feature
//      (3 x 3 blocks) by Schur complement (core/schur_eliminator.h):
//        S = H_xx + lambda D_x - sum_j H_xj (C_j + lambda D_j)^{-1} H_jx
//   2. solve S dx = rhs on a BlockSparseMatrix of 6 x 6 blocks, with
//      CHOLMOD or PCG (block-Jacobi / incomplete Cholesky), as in 2-D
//   3. recover dm_j = -(C_j + lambda D_j)^{-1}(g_j + H_jx dx)
//   4. accept / reject the step and update the trust region: the one
//      Levenberg-Marquardt control of both solvers (core/levenberg_marquardt.h:
//      rho > min_relative_decrease, Nielsen's update, convergence tests,
//      iteration callback, checkpoints).
// D = clamp(diag H) as in 2-D. Observations take the same robust kernel as in
// 2-D (SolverOptions::observation_kernel, IRLS: information scaled by
// rho'(s), chi2 the robust cost), and the relative-pose and GPS constraints
// take pose_kernels.relative_pose / .gps (pose_kernels.motion has no 3-D
// constraint). The gauge is fixed by removing anchor poses
// from the unknowns: fixed poses, else pose 0 unless a GPS constraint ties
// the map to the world.
//
// Differences from the planar loop: the problem is held in memory (no chunk
// source), every observed feature is eliminated (none is kept in the reduced
// system), and the reduced solve is CHOLMOD or plain PCG (block-Jacobi /
// incomplete Cholesky; no forcing sequence or warm start). Features are
// eliminated one after the other, so results do not depend on the number of
// threads.
//
// THREAD SAFETY: one call at a time per problem. ALLOCATION: O(poses +
// features + observations + nonzero 6 x 6 blocks of S).
#pragma once

#include <functional>
#include <vector>

#include "core/graphslam_solver.h"
#include "core/problem_3d.h"
#include "core/robust_kernel.h"
#include "core/status.h"

namespace graphslam::core {

// The 3-D solver's checkpoint (storage/solver_checkpoint.h writes it): the
// control state, poses, points and the partition of the features.
using SolverCheckpoint3d = BasicSolverCheckpoint<Pose3, Point3>;

// Checkpoints of a 3-D solve (the 3-D counterpart of
// SolverOptions::checkpoint_callback / resume_from, which hold 2-D states).
struct Checkpointing3d {
  // Called after every iteration with the state to continue from; an error
  // stops the solve and is returned.
  std::function<Status(const SolverCheckpoint3d&)> callback;  // optional
  // Continue from this state instead of starting over; must outlive the call.
  const SolverCheckpoint3d* resume_from = nullptr;
};

// chi2 = sum e^T Omega e of every constraint of `problem` at (poses, features);
// with `kernel`, observations add rho(e^T Omega e) instead, and relative
// poses and GPS fixes with `pose_kernels.relative_pose` / `.gps`.
double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features);
double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features, const RobustKernel& kernel,
                const PoseFactorKernels& pose_kernels = {});

// Optimizes problem->poses and problem->features in place. Uses from
// `options`: linear_solver, preconditioner, pcg_max_iterations,
// pcg_relative_tolerance, auto_cholmod_max_unknowns, max_iterations,
// tolerances, trust region radii, min_relative_decrease, observation_kernel,
// pose_kernels, progress and iteration_callback; checkpoint_callback and resume_from are
// 2-D states and are ignored (use `checkpointing`).
Status SolveGraphSlam3d(const SolverOptions& options, Problem3d* problem,
                        SolverSummary* summary, const Checkpointing3d& checkpointing = {});

}  // namespace graphslam::core
