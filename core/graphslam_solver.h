// SolveGraphSlam: the GraphSLAM loop of Thrun & Montemerlo (paper Table 5),
// with Levenberg-Marquardt damping so hard problems converge with defaults.
//
// Each iteration, about the current estimate (x, m):
//   1. linearize every constraint (Table 2) and eliminate every feature by
//      Schur complement (Table 3), chunk by chunk:       ReducePass
//        S = H_xx + lambda D_x - sum_j H_xj (C_j + lambda D_j)^{-1} H_jx
//        rhs = -g_x + sum_j H_xj (C_j + lambda D_j)^{-1} g_j
//   2. solve the reduced pose system S dx = rhs: PCG (block-Jacobi, subgraph or
//      incomplete Cholesky preconditioner, inexact-Newton forcing), or CHOLMOD
//      (sparse Cholesky); core/reduced_system_solver.h
//   3. recover each feature (Table 4):  dm_j = -(C_j + lambda D_j)^{-1}(g_j + H_jx dx)
//   4. accept the step if the actual chi2 decrease is a fair share of the
//      model's, rho = (chi2 - chi2') / (-g^T d + lambda d^T D d) > 1e-3, and
//      update the trust region radius mu = 1/lambda as Ceres does (Nielsen):
//      success mu /= max(1/3, 1 - (2 rho - 1)^3); failure mu /= v, v *= 2.
// One pass over the chunks per iteration (fused_chunk_pass): step 3 and, in the
// same visit of every chunk, step 1 of the next iteration at the candidate
// (RecoverAndReducePass), with the lambda an accepted step of rho >= 0.9368
// gives (mu * 3, core/levenberg_marquardt.h). That system is used when the
// step is accepted and the next lambda is that very number (the common case
// near the optimum); otherwise (rejected step, 1e-3 < rho < 0.9368) it is
// dropped and step 1 reduces as usual: two passes on those iterations only.
// The driver speculates after every accepted step (a miss costs the
// eliminations of a reduction, a hit saves a whole pass). A rejected step's
// line search reduces ahead at x (+) t d in its pass too, with the lambda
// the rejection leaves: used when the line step is accepted.
// Either way every iteration solves the same system as with two passes, bit
// for bit, so results do not depend on the option.
// Pose graphs (no observations): an accepted step (at least 1/4 of the
// previous one) is replaced by its Anderson extrapolation over the last
// anderson_depth accepted steps when that lowers chi2 further
// (core/anderson_acceleration.h; one more chi2 evaluation of the pose
// factors, no factorization). Gauss-Newton
// converges only linearly where the residuals bend along a soft mode
// (torus3D: 61 iterations, 31 with it); where it converges quadratically the
// plain step wins and nothing changes.
// Convergence (Ceres' criteria): relative chi2 decrease below
// function_tolerance, |dx| below parameter_tolerance (|x| + tol), or
// max |g| below gradient_tolerance; also a rejected step whose model
// decrease is below model_tolerance (or function_tolerance) x chi2
// (core/levenberg_marquardt.h).
// D is diag(H) clamped to [1e-6, 1e32]. Solving for increments (H d = -g) and
// removing the anchor from the unknowns keep the system well conditioned.
//
// Observations come only through the ChunkSource (problem->observations is not
// read), so the out-of-core store swaps the source, not this loop. The loop is
// written once for the planar and the 3-D space (core/internal/chunked_solve.h;
// SolveGraphSlam3d in core/graphslam_solver_3d.h is its 3-D instance).
//
// THREAD SAFETY: one call at a time per problem; internally parallel (TBB,
// bounded by the caller's tbb::global_control). Results do not depend on the
// number of threads. ALLOCATION: O(poses + features + nonzero blocks of S)
// plus max_chunks_in_flight chunks. The fused pass reduces the next system
// into S's own buffer (S is dead once solved), so it costs no second S.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/candidate_store.h"
#include "core/chunk_source.h"
#include "core/pcg_solver_state.h"
#include "core/problem.h"
#include "core/progress.h"
#include "core/robust_kernel.h"
#include "core/status.h"

namespace graphslam::core {

enum class LinearSolverType { kAuto, kPcg, kCholmod };
enum class PreconditionerType { kBlockJacobi, kIncompleteCholesky, kSubgraph };
const char* LinearSolverName(LinearSolverType type);
StatusOr<LinearSolverType> ParseLinearSolverType(std::string_view name);
const char* PreconditionerName(PreconditionerType type);
StatusOr<PreconditionerType> ParsePreconditionerType(std::string_view name);

struct IterationSummary {
  int iteration = 0;              // 1-based
  double chi2 = 0.0;              // after the iteration (the accepted state)
  double start_chi2 = 0.0;        // at the linearization point (before the step)
  double candidate_chi2 = 0.0;    // at the trial point
  double step_norm = 0.0;         // |(dx, dm)|
  double gradient_max_norm = 0.0; // max |g_x| at the linearization point
  int linear_iterations = 0;      // PCG iterations (1 for CHOLMOD)
  double lambda = 0.0;            // damping used
  double relative_decrease = 0.0; // rho
  bool accepted = false;
  bool accelerated = false;       // the Anderson step was taken instead
  // > 0: the full step was rejected and x (+) t d, t this, was accepted
  // (core/levenberg_marquardt.h, line search).
  double line_search_fraction = 0.0;
  double seconds = 0.0;
  double reduce_seconds = 0.0;   // linearize + eliminate (one pass over the chunks)
  double solve_seconds = 0.0;    // reduced system solve
  double recover_seconds = 0.0;  // recover features + evaluate (one pass)
  // Passes over the observation chunks: 1 when the previous iteration's
  // fused pass already reduced at this state, else 2.
  int chunk_passes = 0;
};

// Everything the loop carries from one iteration to the next: a solve resumed
// from a checkpoint continues exactly as the uninterrupted one would have
// (same steps, same damping, bit for bit). One template for the planar and
// the 3-D solver (SolverCheckpoint3d in core/graphslam_solver_3d.h); the
// control fields are filled by core/levenberg_marquardt.h.
template <class PoseT, class PointT>
struct BasicSolverCheckpoint {
  int iterations = 0;  // iterations completed
  double trust_region_radius = 0.0;
  double decrease_factor = 2.0;
  double initial_chi2 = 0.0;
  double chi2 = 0.0;
  bool converged = false;
  std::string termination;
  std::vector<PoseT> poses;
  std::vector<PointT> features;
  std::vector<uint8_t> excluded;  // per feature: kept out of the solve
  std::vector<uint8_t> kept;      // per feature: unknown of the reduced system
  // The PCG's forcing term, warm start and forest (not present for CHOLMOD).
  PcgSolverState pcg;
};
using SolverCheckpoint = BasicSolverCheckpoint<Pose2, Point2>;

// The initial trust region radius that `initial_trust_region_radius = 0`
// asks for, by the linear solver chosen: nearly undamped for CHOLMOD, where
// lambda * diag(H) = 1e-4 holds back a long pose chain's smallest eigenmodes
// (M3500: 26 iterations instead of 6;
// docs/history/benchmarks-notebook-2026-11.md);
// 1e4 for PCG, whose solves the damping conditions.
inline constexpr double kDirectInitialTrustRegion = 1e8;
inline constexpr double kIterativeInitialTrustRegion = 1e4;

struct SolverOptions {
  LinearSolverType linear_solver = LinearSolverType::kAuto;
  int max_iterations = 100;
  double function_tolerance = 1e-6;
  // A rejected step whose model decrease (-g^T d + lambda d^T D d, the
  // quadratic model's estimate of the chi2 still to gain) is below
  // max(model_tolerance, function_tolerance) x chi2 ends the solve, converged
  // (core/levenberg_marquardt.h, ModelDecreaseBelowTolerance). 0: only the
  // function tolerance.
  double model_tolerance = 1e-4;
  double gradient_tolerance = 1e-10;
  double parameter_tolerance = 1e-8;
  // > 0: the radius (1 / initial lambda); 0: by the linear solver chosen
  // (kDirectInitialTrustRegion, kIterativeInitialTrustRegion).
  double initial_trust_region_radius = 1e4;
  double max_trust_region_radius = 1e16;
  double min_trust_region_radius = 1e-32;
  double min_relative_decrease = 1e-3;
  // > 0: stop at the first step whose ratio rho is below this (a rejected
  // step counts), with termination "abandoned" and converged false. A caller
  // probing whether a start is in the basin of the optimum (rho < 1/4: the
  // quadratic model failed) restarts from a better guess then
  // (tools/solve_command.cc, --initialization auto). 0: off.
  double abandon_below_rho = 0.0;
  // Pose graphs only (no observations): Anderson acceleration over this many
  // past accepted steps (0: off; see the header comment). Off as well with a
  // checkpoint callback or a resume: its history is not in the checkpoint,
  // and a resumed solve must take the uninterrupted one's steps.
  int anderson_depth = 3;
  PreconditionerType preconditioner = PreconditionerType::kSubgraph;  // for PCG (docs/tuning.md)
  int pcg_max_iterations = 2000;
  double pcg_relative_tolerance = 1e-10;
  // PCG: Eisenstat-Walker forcing sequence and warm starts
  // (core/reduced_system_solver.h).
  bool pcg_forcing_sequence = true;
  double pcg_eta_max = 0.01;  // the loosest forcing term (docs/tuning.md)
  // PCG: stop a solve once the chi2 decrease it still misses is estimated
  // below pcg_truncation * function_tolerance * chi2 (0: off;
  // core/reduced_system_solver.h item 2b). Landmark problems only (features
  // eliminated into S): on the pose graphs intel and M3500 it saved 0.2-3.5 %
  // of the CG iterations and cost 2-3 LM iterations
  // (docs/history/benchmarks-notebook-2026-11.md).
  double pcg_truncation = 0.1;
  bool pcg_warm_start = true;
  // PCG: trajectory deflation, poses per aggregate (0: off;
  // core/trajectory_deflation.h).
  int pcg_deflation_poses = 0;
  // kAuto: CHOLMOD when its factor (from its symbolic analysis) fits in
  // auto_cholmod_max_factor_bytes and is estimated cheaper than PCG; PCG
  // without analysing above auto_cholmod_max_unknowns scalar pose unknowns.
  int64_t auto_cholmod_max_unknowns = 3'000'000;
  int64_t auto_cholmod_max_factor_bytes = int64_t{4} << 30;
  // linear_solver kCholmod: called with the factor's bytes (8 lnz) from
  // CHOLMOD's symbolic analysis before the first factorization; an error
  // stops the solve (core/reduced_system_solver.h). Unset: no check.
  std::function<Status(double factor_bytes)> cholmod_factor_check;
  int max_chunks_in_flight = 8;
  // One pass over the chunks per well-accepted iteration instead of two (see
  // the header comment); off: always two passes. Same results either way.
  bool fused_chunk_pass = true;
  // Features with more observations than this stay unknowns of the reduced
  // system instead of being eliminated (their k^2 fill would explode).
  int64_t max_eliminated_observations = 64;
  // Applied to every observation (IRLS); chi2 is then the robust cost.
  RobustKernel observation_kernel;
  // Applied to the relative-pose, velocity-motion and GPS constraints (IRLS).
  PoseFactorKernels pose_kernels;
  // Called after every iteration with the state to continue from; an error
  // (e.g. the disk is full) stops the solve and is returned.
  std::function<Status(const SolverCheckpoint&)> checkpoint_callback;  // optional
  // Continue from this state instead of starting over; must outlive the call.
  // Its `features` may be empty when the caller has moved them into
  // problem->features (no second copy of the estimates during the solve).
  const SolverCheckpoint* resume_from = nullptr;
  // Optional (2-D only): each step's candidate feature estimates go to this
  // store (e.g. a file, storage/candidate_file.h) instead of an in-memory
  // array of one per feature; same results bit for bit. Must outlive the call.
  CandidateStore* candidate_store = nullptr;
  ProgressCallback progress;                                  // optional
  std::function<void(const IterationSummary&)> iteration_callback;  // optional

  Status Validate() const;
};

struct SolverSummary {
  double initial_chi2 = 0.0;
  double final_chi2 = 0.0;
  int iterations = 0;  // Levenberg-Marquardt iterations, accepted or not
  std::vector<IterationSummary> per_iteration;
  LinearSolverType linear_solver_used = LinearSolverType::kCholmod;
  std::string termination;  // "function_tolerance", "max_iterations", ...
  bool converged = false;
  int64_t unknown_poses = 0;
  int64_t eliminated_features = 0;
  int64_t kept_features = 0;       // unknowns of the reduced system (many observations)
  int64_t excluded_features = 0;   // not positive definite: kept out of the solve
  int64_t unobserved_features = 0;
  int64_t observations_used = 0;
  int64_t reduced_nonzero_blocks = 0;
  double seconds = 0.0;
  std::vector<uint8_t> excluded;   // per feature: 1 if kept out of the solve
  int resumed_from_iteration = 0;  // > 0 when continued from a checkpoint
};

// Optimizes problem->poses and problem->features in place. `chunks` holds the
// observations of `problem` (feature indices refer to problem->features).
Status SolveGraphSlam(const SolverOptions& options, const ChunkSource& chunks,
                      Problem2d* problem, SolverSummary* summary);

}  // namespace graphslam::core
