#include "core/graphslam_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "core/angle.h"
#include "core/block_sparse_matrix.h"
#include "core/chunk_passes.h"
#include "core/logging.h"
#include "core/pose_factors.h"
#include "core/reduced_system_solver.h"
#include "core/unknown_layout.h"

namespace graphslam::core {
namespace {

constexpr int kDim = UnknownLayout::kPoseDimension;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

std::vector<Pose2> ApplyPoseStep(const std::vector<Pose2>& poses, const UnknownLayout& layout,
                                 const Eigen::VectorXd& step) {
  std::vector<Pose2> out = poses;
  for (size_t p = 0; p < poses.size(); ++p) {
    const int32_t u = layout.unknown_index[p];
    if (u < 0) continue;
    out[p] = RetractPose(poses[p], step.segment<kDim>(kDim * u));
  }
  return out;
}

}  // namespace

const char* LinearSolverName(LinearSolverType type) {
  switch (type) {
    case LinearSolverType::kAuto: return "auto";
    case LinearSolverType::kPcg: return "pcg";
    case LinearSolverType::kCholmod: return "cholmod";
  }
  return "unknown";
}

StatusOr<LinearSolverType> ParseLinearSolverType(std::string_view name) {
  if (name == "auto") return LinearSolverType::kAuto;
  if (name == "pcg") return LinearSolverType::kPcg;
  if (name == "cholmod") return LinearSolverType::kCholmod;
  return Status::InvalidArgument("unknown linear solver '" + std::string(name) +
                                 "'; expected auto, pcg or cholmod");
}

const char* PreconditionerName(PreconditionerType type) {
  switch (type) {
    case PreconditionerType::kBlockJacobi: return "block-jacobi";
    case PreconditionerType::kIncompleteCholesky: return "incomplete-cholesky";
    case PreconditionerType::kSubgraph: return "subgraph";
  }
  return "unknown";
}

StatusOr<PreconditionerType> ParsePreconditionerType(std::string_view name) {
  if (name == "block-jacobi") return PreconditionerType::kBlockJacobi;
  if (name == "incomplete-cholesky") return PreconditionerType::kIncompleteCholesky;
  if (name == "subgraph") return PreconditionerType::kSubgraph;
  return Status::InvalidArgument("unknown preconditioner '" + std::string(name) +
                                 "'; expected block-jacobi, incomplete-cholesky or subgraph");
}

Status SolverOptions::Validate() const {
  if (max_iterations < 0)
    return Status::InvalidArgument("max_iterations must be >= 0, got " +
                                   std::to_string(max_iterations));
  if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(parameter_tolerance >= 0))
    return Status::InvalidArgument("tolerances must be non-negative");
  if (!(initial_trust_region_radius > 0) ||
      !(max_trust_region_radius >= initial_trust_region_radius))
    return Status::InvalidArgument(
        "trust region radii must satisfy 0 < initial <= max");
  if (pcg_max_iterations <= 0 || !(pcg_relative_tolerance > 0))
    return Status::InvalidArgument("PCG needs max_iterations > 0 and relative_tolerance > 0");
  if (max_eliminated_observations < 0)
    return Status::InvalidArgument("max_eliminated_observations must be >= 0");
  if (max_chunks_in_flight <= 0)
    return Status::InvalidArgument("max_chunks_in_flight must be > 0");
  return Status::Ok();
}

Status SolveGraphSlam(const SolverOptions& options, const ChunkSource& chunks,
                      Problem2d* problem, SolverSummary* summary) {
  GS_RETURN_IF_ERROR(options.Validate());
  const Clock::time_point start = Clock::now();
  *summary = SolverSummary();

  UnknownLayout layout = UnknownLayout::FromProblem(*problem);
  summary->unknown_poses = layout.num_unknown_poses;
  PassContext context;
  context.chunks = &chunks;
  context.layout = &layout;
  context.max_in_flight = options.max_chunks_in_flight;
  context.progress = options.progress;
  context.kernel = options.observation_kernel;

  // Which features can be eliminated (positive definite information).
  ScreeningResult screening;
  GS_RETURN_IF_ERROR(ScreenFeatures(context, problem->poses, problem->features,
                                    options.max_eliminated_observations, &screening));
  const SolverCheckpoint* resume = options.resume_from;
  if (resume != nullptr) {
    if (resume->poses.size() != problem->poses.size() ||
        resume->features.size() != problem->features.size() ||
        resume->excluded.size() != problem->features.size() ||
        resume->kept.size() != problem->features.size()) {
      return Status::InvalidArgument(
          "checkpoint does not match the problem: " + std::to_string(resume->poses.size()) +
          " poses and " + std::to_string(resume->features.size()) + " features, expected " +
          std::to_string(problem->poses.size()) + " and " +
          std::to_string(problem->features.size()));
    }
    // The checkpoint's partition of the features, not one recomputed at the
    // resumed state: the continued solve must be the interrupted one.
    const int64_t unobserved = screening.unobserved;
    screening.excluded = resume->excluded;
    screening.kept = resume->kept;
    screening.kept_count = std::count(screening.kept.begin(), screening.kept.end(), 1);
    screening.excluded_not_positive_definite =
        std::count(screening.excluded.begin(), screening.excluded.end(), 1) - unobserved;
    problem->poses = resume->poses;
    problem->features = resume->features;
    summary->resumed_from_iteration = resume->iterations;
  }
  layout.KeepFeatures(screening.kept);
  summary->kept_features = screening.kept_count;
  summary->excluded_features = screening.excluded_not_positive_definite;
  summary->unobserved_features = screening.unobserved;
  summary->observations_used = screening.observations;
  summary->eliminated_features =
      problem->num_features() - screening.excluded_not_positive_definite - screening.unobserved -
      screening.kept_count;
  if (screening.excluded_not_positive_definite > 0) {
    GS_LOG(WARNING,
           "%lld features have information that is not positive definite (too few or "
           "degenerate observations); they are kept out of the solve",
           static_cast<long long>(screening.excluded_not_positive_definite));
  }
  summary->excluded = screening.excluded;
  context.excluded = &summary->excluded;

  // The reduced matrix's pattern: pose-only factors plus co-observing poses.
  std::vector<std::pair<int, int>> pairs;
  AppendPoseFactorPattern(*problem, layout, &pairs);
  GS_RETURN_IF_ERROR(CollectReducedPattern(context, &pairs));
  ReducedSystem system;
  system.matrix = BlockSparseMatrix::FromPattern(kDim, layout.num_blocks(), std::move(pairs));
  pairs = {};
  summary->reduced_nonzero_blocks = system.matrix.num_nonzero_blocks();

  // The reduced system's solver (core/reduced_system_solver.h): kAuto picks
  // CHOLMOD or PCG from CHOLMOD's symbolic analysis of this pattern.
  ReducedSystemSolverOptions linear_options;
  linear_options.type = options.linear_solver;
  linear_options.preconditioner = options.preconditioner;
  linear_options.pcg_max_iterations = options.pcg_max_iterations;
  linear_options.pcg_relative_tolerance = options.pcg_relative_tolerance;
  linear_options.forcing_sequence = options.pcg_forcing_sequence;
  linear_options.eta_max = options.pcg_eta_max;
  linear_options.warm_start = options.pcg_warm_start;
  linear_options.max_analysis_unknowns = options.auto_cholmod_max_unknowns;
  linear_options.max_factor_bytes = options.auto_cholmod_max_factor_bytes;
  GS_RETURN_IF_ERROR(linear_options.Validate());
  StatusOr<SolverChoice> choice = ChooseLinearSolver(system.matrix, linear_options);
  GS_RETURN_IF_ERROR(choice.status());
  const LinearSolverType type = choice->type;
  if (choice->analyzed) {
    GS_VLOG(1, "solver choice: CHOLMOD factor %.3g nonzeros, %.3g flops; PCG estimate %.3g "
            "flops -> %s", choice->factor_nonzeros, choice->factor_flops, choice->pcg_cost,
            LinearSolverName(type));
  }
  summary->linear_solver_used = type;
  ReducedSystemSolver solver(type, linear_options);

  std::vector<Pose2>& poses = problem->poses;
  std::vector<Point2>& features = problem->features;
  double observations_chi2 = 0.0;
  GS_RETURN_IF_ERROR(ObservationsChi2(context, poses, features, &observations_chi2));
  double chi2 = PoseFactorsChi2(*problem, poses, options.pose_kernels) + observations_chi2;
  summary->initial_chi2 = chi2;
  summary->final_chi2 = chi2;
  if (!std::isfinite(chi2)) {
    return Status::Numerical("initial chi2 is not finite (" + std::to_string(chi2) +
                             "); check the initial guess and information matrices");
  }

  double radius = options.initial_trust_region_radius;
  double decrease_factor = 2.0;
  int first_iteration = 1;
  if (resume != nullptr) {
    // The checkpoint's chi2, not a recomputation: acceptance decisions must
    // see the very number the interrupted solve saw.
    chi2 = resume->chi2;
    summary->final_chi2 = chi2;
    summary->initial_chi2 = resume->initial_chi2;
    radius = resume->trust_region_radius;
    decrease_factor = resume->decrease_factor;
    first_iteration = resume->iterations + 1;
    summary->iterations = resume->iterations;
    if (resume->converged) {
      summary->converged = true;
      summary->termination = resume->termination;
      summary->seconds = SecondsSince(start);
      return Status::Ok();
    }
  }
  std::vector<Point2> candidate_features;
  Eigen::VectorXd pose_step;
  summary->termination = "max_iterations";
  const int num_rows = system.matrix.num_rows();

  for (int iteration = first_iteration; iteration <= options.max_iterations; ++iteration) {
    const Clock::time_point iteration_start = Clock::now();
    IterationSummary it;
    it.iteration = iteration;
    it.lambda = 1.0 / radius;

    // 1. Linearize and reduce.
    system.matrix.SetZero();
    system.rhs.setZero(num_rows);
    system.gradient.setZero(num_rows);
    system.hessian_diagonal.setZero(num_rows);
    system.chi2 = 0.0;
    LinearizePoseFactors(*problem, poses, layout, &system.matrix, &system.gradient,
                         &system.hessian_diagonal, options.pose_kernels);
    system.rhs -= system.gradient;
    GS_RETURN_IF_ERROR(ReducePass(context, poses, features, it.lambda, &system));
    it.reduce_seconds = SecondsSince(iteration_start);
    it.gradient_max_norm = num_rows > 0 ? system.gradient.cwiseAbs().maxCoeff() : 0.0;
    if (it.gradient_max_norm <= options.gradient_tolerance) {
      summary->termination = "gradient_tolerance";
      summary->converged = true;
      break;
    }
    const Eigen::VectorXd damping =
        system.hessian_diagonal.cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
    system.matrix.AddToDiagonal(it.lambda * damping);

    // 2. Solve the reduced pose system.
    const Clock::time_point solve_start = Clock::now();
    Status solve_status = solver.Solve(system.matrix, system.rhs, &pose_step, &it.linear_iterations);
    bool step_ok = solve_status.ok();
    it.solve_seconds = SecondsSince(solve_start);
    const Clock::time_point recover_start = Clock::now();
    if (!step_ok) GS_VLOG(1, "linear solve failed (%s); raising damping", solve_status.ToString().c_str());

    double candidate_chi2 = std::numeric_limits<double>::infinity();
    double model_decrease = 0.0;
    RecoveryResult recovery;
    std::vector<Pose2> candidate_poses;
    if (step_ok) {
      // 3. Recover the features and evaluate the candidate.
      candidate_poses = ApplyPoseStep(poses, layout, pose_step);
      GS_RETURN_IF_ERROR(RecoverPass(context, poses, features, it.lambda, pose_step,
                                     candidate_poses, &candidate_features, &recovery));
      candidate_chi2 = PoseFactorsChi2(*problem, candidate_poses, options.pose_kernels) +
                       recovery.candidate_chi2;
      model_decrease = -(system.gradient.dot(pose_step) + recovery.gradient_dot_step) +
                       it.lambda * (pose_step.dot(damping.cwiseProduct(pose_step)) +
                                    recovery.damped_step_norm);
      it.step_norm = std::sqrt(pose_step.squaredNorm() + recovery.step_squared_norm);
    }
    it.recover_seconds = SecondsSince(recover_start);
    it.candidate_chi2 = candidate_chi2;
    it.relative_decrease =
        model_decrease > 0.0 ? (chi2 - candidate_chi2) / model_decrease : -1.0;
    it.accepted = step_ok && std::isfinite(candidate_chi2) &&
                  it.relative_decrease > options.min_relative_decrease;
    if (step_ok) solver.StepResult(it.accepted);

    bool converged = false;
    if (it.accepted) {
      const double relative_change = (chi2 - candidate_chi2) / std::max(chi2, 1e-300);
      double state_norm_squared = recovery.state_squared_norm;
      for (size_t p = 0; p < poses.size(); ++p)
        if (layout.unknown_index[p] >= 0) state_norm_squared += poses[p].squaredNorm();
      poses = std::move(candidate_poses);
      for (size_t g = 0; g < features.size(); ++g)
        if (!summary->excluded[g]) features[g] = candidate_features[g];
      chi2 = candidate_chi2;
      const double factor = 1.0 - std::pow(2.0 * it.relative_decrease - 1.0, 3);
      radius = std::min(radius / std::max(1.0 / 3.0, factor), options.max_trust_region_radius);
      decrease_factor = 2.0;
      if (relative_change < options.function_tolerance) {
        summary->termination = "function_tolerance";
        converged = true;
      } else if (it.step_norm <= options.parameter_tolerance *
                                     (std::sqrt(state_norm_squared) + options.parameter_tolerance)) {
        summary->termination = "parameter_tolerance";
        converged = true;
      }
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
    }
    it.chi2 = chi2;
    it.seconds = SecondsSince(iteration_start);
    summary->per_iteration.push_back(it);
    summary->iterations = iteration;
    summary->final_chi2 = chi2;
    GS_VLOG(1, "iteration %d: chi2 %.9g candidate %.9g rho %.3g lambda %.3g |step| %.3g cg %d %s",
            iteration, chi2, candidate_chi2, it.relative_decrease, it.lambda, it.step_norm,
            it.linear_iterations, it.accepted ? "accepted" : "rejected");
    if (options.iteration_callback) options.iteration_callback(it);
    if (options.progress) options.progress("optimize", iteration, options.max_iterations);
    if (!converged && radius < options.min_trust_region_radius) {
      summary->termination = "min_trust_region_radius";
      converged = true;  // no further decrease possible: a (local) minimum
    }
    if (options.checkpoint_callback) {
      SolverCheckpoint checkpoint;
      checkpoint.iterations = iteration;
      checkpoint.trust_region_radius = radius;
      checkpoint.decrease_factor = decrease_factor;
      checkpoint.initial_chi2 = summary->initial_chi2;
      checkpoint.chi2 = chi2;
      checkpoint.converged = converged;
      checkpoint.termination = converged ? summary->termination : "";
      checkpoint.poses = poses;
      checkpoint.features = features;
      checkpoint.excluded = summary->excluded;
      checkpoint.kept = screening.kept;
      GS_RETURN_IF_ERROR(options.checkpoint_callback(checkpoint));
    }
    if (converged) {
      summary->converged = true;
      break;
    }
  }
  summary->seconds = SecondsSince(start);
  return Status::Ok();
}

}  // namespace graphslam::core
