// SolveGraphSlam3d: the GraphSLAM loop (paper Table 5) on 3-D problems. It is
// the planar SolveGraphSlam (core/graphslam_solver.h) instantiated for the 3-D
// space (core/internal/chunked_solve.h, core/problem_space.h): SE(3) poses
// with 6 x 6 blocks, 3-D points with 3 x 3 blocks, and the very same
//
//   1. reduce, chunk by chunk (core/chunk_passes.h, ReducePass): linearize
//      against the retraction x (+) d = x Exp(d) (core/se3_lie.h) and
//      eliminate every feature by Schur complement:
//        S = H_xx + lambda D_x - sum_j H_xj (C_j + lambda D_j)^{-1} H_jx
//      features with more than max_eliminated_observations observations are
//      kept as unknowns of S instead (padded to 6 x 6 blocks), features whose
//      information is not positive definite are kept out of the solve;
//   2. solve S dx = rhs with core/reduced_system_solver.h: CHOLMOD, or PCG
//      (subgraph / block-Jacobi / incomplete Cholesky preconditioner,
//      forcing sequence, warm start), kAuto chosen from CHOLMOD's analysis;
//   3. recover dm_j = -(C_j + lambda D_j)^{-1}(g_j + H_jx dx) (RecoverPass),
//      or the fused RecoverAndReducePass (one read of the chunks per
//      well-accepted iteration; SolverOptions::fused_chunk_pass);
//   4. the one Levenberg-Marquardt control (core/levenberg_marquardt.h).
//
// Chunks are eliminated in parallel (TBB) and merged in chunk order, so
// results do not depend on the number of threads. Observations come only
// through the ChunkSource3d (problem->observations is not read): an in-memory
// one cut from the problem (partition/ingest/in_memory_chunk_source.h) or a store.
// The relative-pose and GPS constraints (core/pose_factors.h) take
// pose_kernels.relative_pose / .gps (pose_kernels.motion has no 3-D
// constraint), observations the observation_kernel (IRLS). The gauge is fixed
// by removing anchor poses from the unknowns: fixed poses, else pose 0 unless
// a GPS constraint ties the map to the world.
//
// THREAD SAFETY: one call at a time per problem; internally parallel.
// ALLOCATION: O(poses + features + nonzero 6 x 6 blocks of S) plus
// max_chunks_in_flight chunks.
#pragma once

#include <functional>
#include <vector>

#include "core/chunk_source.h"
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

// Optimizes problem->poses and problem->features in place. `chunks` holds the
// observations of `problem` (feature indices refer to problem->features).
// Uses every field of `options` but checkpoint_callback and resume_from,
// which hold 2-D states (use `checkpointing`).
Status SolveGraphSlam3d(const SolverOptions& options, const ChunkSource3d& chunks,
                        Problem3d* problem, SolverSummary* summary,
                        const Checkpointing3d& checkpointing = {});

}  // namespace graphslam::core
