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
//   4. accept / reject the step and update the trust region exactly as the
//      2-D loop does (rho > min_relative_decrease; Nielsen's update).
// Convergence tests and D = clamp(diag H) are the 2-D ones. The gauge is
// fixed by removing anchor poses from the unknowns: fixed poses, else pose 0
// unless a GPS constraint ties the map to the world.
//
// Differences from the planar loop: the problem is held in memory (no chunk
// source, no checkpoints), observations use no robust kernel, and every
// observed feature is eliminated (none is kept in the reduced system).
// Features are eliminated one after the other, so results do not depend on
// the number of threads.
//
// THREAD SAFETY: one call at a time per problem. ALLOCATION: O(poses +
// features + observations + nonzero 6 x 6 blocks of S).
#pragma once

#include <vector>

#include "core/graphslam_solver.h"
#include "core/problem_3d.h"
#include "core/status.h"

namespace graphslam::core {

// chi2 = sum e^T Omega e of every constraint of `problem` at (poses, features).
double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features);

// Optimizes problem->poses and problem->features in place. Uses from
// `options`: linear_solver, preconditioner, pcg_*, auto_cholmod_max_unknowns,
// max_iterations, tolerances, trust region radii, min_relative_decrease,
// progress and iteration_callback. Other fields are ignored.
Status SolveGraphSlam3d(const SolverOptions& options, Problem3d* problem,
                        SolverSummary* summary);

}  // namespace graphslam::core
