// SolveChunked: the GraphSLAM solve of both problem spaces (core/problem_space.h),
// written once: SolveGraphSlam (core/graphslam_solver.h) is SolveChunked<Space2d>
// and SolveGraphSlam3d (core/graphslam_solver_3d.h) is SolveChunked<Space3d>.
//
//   setup      ScreenFeatures (eliminated / kept / excluded features) and in
//              the same pass the pattern of S (pose factors + the screened
//              pairs; a resume runs CollectReducedPattern for the checkpoint's
//              partition), the choice of the linear solver
//              (core/reduced_system_solver.h), then the first iteration's
//              reduce, which also gives the initial chi2 (fused schedule)
//   iterations RunLevenbergMarquardt (core/levenberg_marquardt.h) over a
//              space whose Linearize is a ReducePass and whose TryStep is a
//              solve plus a RecoverPass, or the fused RecoverAndReducePass
//              (core/chunk_passes.h; the schedule is described in
//              core/graphslam_solver.h)
//
// The pose-only factors come from the templates LinearizePoseFactors /
// PoseFactorsChi2 / AppendPoseFactorPattern of core/pose_factors.h, on
// Space::Problem. The body is SolveChunkedWith
// (chunked_solve_impl.h) with the one-process policy (single_process.h);
// instantiated for the two spaces in chunked_solve.cc. The solve over MPI
// ranks (distributed/distributed_solve.h) runs the same body.
//
// THREAD SAFETY and ALLOCATION: as SolveGraphSlam.
#pragma once

#include <functional>

#include "core/chunk_source.h"
#include "core/graphslam_solver.h"
#include "core/problem_space.h"
#include "core/status.h"

namespace graphslam::core::internal {

template <class Space>
using CheckpointOf = BasicSolverCheckpoint<typename Space::Pose, typename Space::Point>;

// `resume` (optional) must outlive the call; `checkpoint_callback` is optional.
template <class Space>
Status SolveChunked(
    const SolverOptions& options, const BasicChunkSource<typename Space::Observation>& chunks,
    typename Space::Problem* problem, SolverSummary* summary, const CheckpointOf<Space>* resume,
    const std::function<Status(const CheckpointOf<Space>&)>& checkpoint_callback);

}  // namespace graphslam::core::internal
