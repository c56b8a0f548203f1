#include "core/internal/chunked_solve.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <type_traits>

#include "core/block_sparse_matrix.h"
#include "core/candidate_store.h"
#include "core/chunk_passes.h"
#include "core/levenberg_marquardt.h"
#include "core/logging.h"
#include "core/pose_factors.h"
#include "core/pose_factors_3d.h"
#include "core/reduced_system_solver.h"
#include "core/unknown_layout.h"

namespace graphslam::core::internal {
namespace {

using Clock = SolverClock;

template <class Space>
std::vector<typename Space::Pose> ApplyPoseStep(const std::vector<typename Space::Pose>& poses,
                                                const UnknownLayout& layout,
                                                const Eigen::VectorXd& step) {
  constexpr int P = Space::kPoseDim;
  std::vector<typename Space::Pose> out = poses;
  for (size_t p = 0; p < poses.size(); ++p) {
    const int32_t u = layout.unknown_index[p];
    if (u < 0) continue;
    out[p] = Space::Retract(poses[p], step.template segment<P>(P * u));
  }
  return out;
}

// The problem space of RunLevenbergMarquardt (core/levenberg_marquardt.h)
// for either space: observations streamed from the ChunkSource chunk by
// chunk (core/chunk_passes.h), the pose-only factors from the problem.
template <class Space>
class ChunkedSpace {
 public:
  using Checkpoint = CheckpointOf<Space>;
  static constexpr const char* kName = Space::kName;
  using Pose = typename Space::Pose;
  using Point = typename Space::Point;

  // fused: one RecoverAndReducePass per accepted iteration (see TryStep).
  // candidate_store (optional): the step's candidate features go there
  // instead of into an array of one per feature (core/candidate_store.h).
  // kept and excluded are lent to the checkpoint too (LendState), so they
  // are held by non-const reference.
  ChunkedSpace(const BasicPassContext<Space>& context, const UnknownLayout& layout,
               std::vector<uint8_t>* kept, const PoseFactorKernels& pose_kernels,
               typename Space::Problem* problem, ReducedSystem* system,
               ReducedSystemSolver* solver, std::vector<uint8_t>* excluded, bool fused,
               BasicCandidateStore<Point>* candidate_store)
      : context_(context), layout_(layout), kept_(*kept), pose_kernels_(pose_kernels),
        problem_(*problem), system_(*system), solver_(*solver), excluded_(*excluded),
        fused_(fused), candidate_store_(candidate_store) {}

  Status Linearize(double lambda, IterationSummary* it, bool* usable) {
    const int num_rows = system_.matrix.num_rows();
    *usable = true;
    if (speculation_ready_ && lambda == speculative_lambda_) {
      // The previous iteration's fused pass reduced at this very state with
      // this very lambda into system_ (RecoverAndReducePass): no pass.
      speculation_ready_ = false;
      it->gradient_max_norm = num_rows > 0 ? system_.gradient.cwiseAbs().maxCoeff() : 0.0;
      return Status::Ok();
    }
    speculation_ready_ = false;
    ResetSystem(problem_.poses, &system_);
    GS_RETURN_IF_ERROR(
        ReducePass(context_, problem_.poses, problem_.features, lambda, &system_));
    ++it->chunk_passes;
    it->gradient_max_norm = num_rows > 0 ? system_.gradient.cwiseAbs().maxCoeff() : 0.0;
    return Status::Ok();
  }

  // Reduces at the current state with damping lambda before the first
  // iteration, whose Linearize(lambda) then reuses the system (as after an
  // accepted fused step); *observations_chi2 is the system's chi2, the sum
  // ObservationsChi2 gives, in the same order. This pass replaces the
  // separate initial-cost pass. On an error nothing is reused: the caller
  // falls back to ObservationsChi2, and Linearize reduces (and fails) again.
  Status ReduceAhead(double lambda, double* observations_chi2) {
    speculation_ready_ = false;
    ResetSystem(problem_.poses, &system_);
    GS_RETURN_IF_ERROR(
        ReducePass(context_, problem_.poses, problem_.features, lambda, &system_));
    speculation_ready_ = true;
    speculative_lambda_ = lambda;
    *observations_chi2 = system_.chi2;
    return Status::Ok();
  }

  Status TryStep(double lambda, double speculative_lambda, bool /*usable*/, IterationSummary* it,
                 TrialStep* trial) {
    const std::vector<Pose>& poses = problem_.poses;
    damping_ = system_.hessian_diagonal.cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
    system_.matrix.AddToDiagonal(lambda * damping_);
    speculation_built_ = false;

    // Solve the reduced pose system.
    const Clock::time_point solve_start = Clock::now();
    Status solve_status =
        solver_.Solve(system_.matrix, system_.rhs, &pose_step_, &it->linear_iterations,
                      it->start_chi2);
    trial->ok = solve_status.ok();
    it->solve_seconds = SecondsSince(solve_start);
    const Clock::time_point recover_start = Clock::now();
    if (!trial->ok)
      GS_VLOG(1, "linear solve failed (%s); raising damping", solve_status.ToString().c_str());
    if (trial->ok) {
      // Recover the features and evaluate the candidate; in the same pass,
      // reduce at the candidate for the next iteration when there is one.
      RecoveryResult recovery;
      candidate_poses_ = ApplyPoseStep<Space>(poses, layout_, pose_step_);
      CandidateSink<Space> sink = CandidateSinkForThisStep();
      if (candidate_store_ != nullptr) GS_RETURN_IF_ERROR(candidate_store_->Begin());
      if (fused_ && speculative_lambda > 0.0) {
        // Once solved, this linearization's matrix and rhs are dead (a
        // rejected step re-reduces at x from scratch): the next system is
        // reduced into the same buffer. Only g_x is still needed, for the
        // model decrease below.
        step_gradient_.swap(system_.gradient);
        ResetSystem(candidate_poses_, &system_);
        Status next_status;
        GS_RETURN_IF_ERROR(RecoverAndReducePass<Space>(
            context_, poses, problem_.features, lambda, pose_step_, candidate_poses_, sink,
            &recovery, speculative_lambda, &system_, &next_status));
        speculation_built_ = next_status.ok();
        speculative_lambda_ = speculative_lambda;
        if (!next_status.ok())
          GS_VLOG(1, "speculative reduce failed (%s)", next_status.ToString().c_str());
      } else {
        GS_RETURN_IF_ERROR(RecoverPass<Space>(context_, poses, problem_.features, lambda,
                                              pose_step_, candidate_poses_, sink, &recovery));
        step_gradient_ = system_.gradient;
      }
      if (candidate_store_ != nullptr) GS_RETURN_IF_ERROR(candidate_store_->Finish());
      ++it->chunk_passes;
      trial->candidate_chi2 =
          PoseFactorsChi2(problem_, candidate_poses_, pose_kernels_) + recovery.candidate_chi2;
      trial->model_decrease = -(step_gradient_.dot(pose_step_) + recovery.gradient_dot_step) +
                              lambda * (pose_step_.dot(damping_.cwiseProduct(pose_step_)) +
                                        recovery.damped_step_norm);
      it->step_norm = std::sqrt(pose_step_.squaredNorm() + recovery.step_squared_norm);
      trial->state_norm_squared = recovery.state_squared_norm;
      for (size_t p = 0; p < poses.size(); ++p) {
        if (layout_.unknown_index[p] >= 0)
          trial->state_norm_squared += Space::StateSquaredNorm(poses[p]);
      }
    }
    it->recover_seconds = SecondsSince(recover_start);
    return Status::Ok();
  }

  void StepResult(bool accepted) { solver_.StepResult(accepted); }

  Status Accept() {
    // The speculative system was reduced at exactly the state taken here.
    speculation_ready_ = speculation_built_;
    problem_.poses = std::move(candidate_poses_);
    if (candidate_store_ != nullptr) {
      std::vector<Point>& features = problem_.features;
      const std::vector<uint8_t>& excluded = excluded_;
      return candidate_store_->ForEach([&](int32_t g, const Point& value) {
        if (!excluded[g]) features[g] = value;
      });
    }
    for (size_t g = 0; g < problem_.features.size(); ++g)
      if (!excluded_[g]) problem_.features[g] = candidate_features_[g];
    return Status::Ok();
  }

  // Moves (not copies) the poses, feature estimates and per-feature flags
  // into the checkpoint for the callback; ReturnState must follow before the
  // state is used again. A moved vector keeps its buffer, so the state comes
  // back at the same addresses (context_.excluded points at excluded_).
  void LendState(Checkpoint* checkpoint) {
    checkpoint->poses = std::move(problem_.poses);
    checkpoint->features = std::move(problem_.features);
    checkpoint->excluded = std::move(excluded_);
    checkpoint->kept = std::move(kept_);
    solver_.SaveState(&checkpoint->pcg);
  }

  void ReturnState(Checkpoint* checkpoint) {
    problem_.poses = std::move(checkpoint->poses);
    problem_.features = std::move(checkpoint->features);
    excluded_ = std::move(checkpoint->excluded);
    kept_ = std::move(checkpoint->kept);
  }

 private:
  // Where RecoverChunk's per-chunk candidates go: the store, or one slot per
  // feature in candidate_features_.
  CandidateSink<Space> CandidateSinkForThisStep() {
    using Chunk = BasicObservationChunk<typename Space::Observation>;
    if (candidate_store_ != nullptr) {
      return [this](const Chunk& chunk, const std::vector<Point>& candidates) {
        return candidate_store_->Append(chunk.index, chunk.features.data(), candidates.data(),
                                        chunk.num_features());
      };
    }
    candidate_features_.resize(problem_.features.size());
    return [this](const Chunk& chunk, const std::vector<Point>& candidates) {
      for (int64_t k = 0; k < chunk.num_features(); ++k) {
        const int32_t g = chunk.features[k];
        if (!excluded_[g]) candidate_features_[g] = candidates[static_cast<size_t>(k)];
      }
      return Status::Ok();
    };
  }

  // Zeroes *system and adds the pose-only factors at `poses`: the state
  // ReducePass (or the reduce half of the fused pass) starts from.
  void ResetSystem(const std::vector<Pose>& poses, ReducedSystem* system) const {
    const int num_rows = system->matrix.num_rows();
    system->matrix.SetZero();
    system->rhs.setZero(num_rows);
    system->gradient.setZero(num_rows);
    system->hessian_diagonal.setZero(num_rows);
    system->chi2 = 0.0;
    LinearizePoseFactors(problem_, poses, layout_, &system->matrix, &system->gradient,
                         &system->hessian_diagonal, pose_kernels_);
    system->rhs -= system->gradient;
  }

  const BasicPassContext<Space>& context_;
  const UnknownLayout& layout_;
  std::vector<uint8_t>& kept_;
  const PoseFactorKernels& pose_kernels_;
  typename Space::Problem& problem_;
  ReducedSystem& system_;
  ReducedSystemSolver& solver_;
  std::vector<uint8_t>& excluded_;
  const bool fused_;
  BasicCandidateStore<Point>* const candidate_store_;  // may be null
  Eigen::VectorXd step_gradient_;  // g_x of the linearization the last step solved
  Eigen::VectorXd damping_;
  Eigen::VectorXd pose_step_;
  std::vector<Pose> candidate_poses_;
  std::vector<Point> candidate_features_;
  // Speculation: system_ holds the reduction at the last candidate (built by
  // the last TryStep); ready once that step was accepted.
  bool speculation_built_ = false;
  bool speculation_ready_ = false;
  double speculative_lambda_ = 0.0;
};

}  // namespace

template <class Space>
Status SolveChunked(
    const SolverOptions& options, const BasicChunkSource<typename Space::Observation>& chunks,
    typename Space::Problem* problem, SolverSummary* summary, const CheckpointOf<Space>* resume,
    const std::function<Status(const CheckpointOf<Space>&)>& checkpoint_callback) {
  constexpr int kDim = Space::kPoseDim;
  GS_RETURN_IF_ERROR(options.Validate());
  const Clock::time_point start = Clock::now();
  *summary = SolverSummary();

  UnknownLayout layout = UnknownLayout::FromProblem(*problem);
  summary->unknown_poses = layout.num_unknown_poses;
  BasicPassContext<Space> context;
  context.chunks = &chunks;
  context.layout = &layout;
  context.max_in_flight = options.max_chunks_in_flight;
  context.progress = options.progress;
  context.kernel = options.observation_kernel;

  // Which features can be eliminated (positive definite information), and in
  // the same pass the pattern of S under that partition. A resume keeps the
  // checkpoint's partition instead, whose pattern takes a pass of its own.
  ScreeningResult screening;
  ScreenedPattern screened_pattern;
  GS_RETURN_IF_ERROR(ScreenFeatures(context, problem->poses, problem->features,
                                    options.max_eliminated_observations, &screening,
                                    resume == nullptr ? &screened_pattern : nullptr));
  // A resume whose feature array is empty while the problem has features:
  // the caller moved the checkpoint's estimates into problem->features
  // already (SolverOptions::resume_from), so no second copy is held.
  const bool resume_features_in_problem =
      resume != nullptr && resume->features.empty() && !problem->features.empty();
  if (resume != nullptr) {
    if (resume->poses.size() != problem->poses.size() ||
        (!resume_features_in_problem && resume->features.size() != problem->features.size()) ||
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
    if (!resume_features_in_problem) problem->features = resume->features;
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
  // Moved, not copied: one byte per feature (the screening's copy is dead).
  summary->excluded = std::move(screening.excluded);
  context.excluded = &summary->excluded;

  // The reduced matrix's pattern: pose-only factors plus co-observing poses.
  std::vector<std::pair<int, int>> pairs;
  AppendPoseFactorPattern(*problem, layout, &pairs);
  if (resume == nullptr) {
    AppendScreenedPattern(layout, &screened_pattern, &pairs);
  } else {
    GS_RETURN_IF_ERROR(CollectReducedPattern(context, &pairs));
  }
  ReducedSystem system;
  system.matrix = BlockSparseMatrix::FromPattern(kDim, layout.num_blocks(), std::move(pairs));
  pairs = {};
  summary->reduced_nonzero_blocks = system.matrix.num_nonzero_blocks();
  GS_VLOG(1, "reduced system: %d poses, %lld stored blocks; product: %d ranges, %lld accumulator rows, "
          "%lld far blocks", system.matrix.num_block_rows(),
          static_cast<long long>(system.matrix.num_stored_blocks()),
          system.matrix.num_product_ranges(), static_cast<long long>(system.matrix.num_accumulator_rows()),
          static_cast<long long>(system.matrix.num_far_blocks()));

  // The reduced system's solver (core/reduced_system_solver.h): kAuto picks
  // CHOLMOD or PCG from CHOLMOD's symbolic analysis of this pattern.
  ReducedSystemSolverOptions linear_options;
  linear_options.type = options.linear_solver;
  linear_options.preconditioner = options.preconditioner;
  linear_options.pcg_max_iterations = options.pcg_max_iterations;
  linear_options.pcg_relative_tolerance = options.pcg_relative_tolerance;
  linear_options.forcing_sequence = options.pcg_forcing_sequence;
  linear_options.eta_max = options.pcg_eta_max;
  // Landmark problems only (core/graphslam_solver.h, pcg_truncation).
  linear_options.truncation = summary->eliminated_features > 0
                                  ? options.pcg_truncation * options.function_tolerance
                                  : 0.0;
  linear_options.warm_start = options.pcg_warm_start;
  linear_options.deflation_poses = options.pcg_deflation_poses;
  linear_options.max_analysis_unknowns = options.auto_cholmod_max_unknowns;
  linear_options.max_factor_bytes = options.auto_cholmod_max_factor_bytes;
  linear_options.eliminated_features = summary->eliminated_features > 0;
  GS_RETURN_IF_ERROR(linear_options.Validate());
  StatusOr<SolverChoice> choice = ChooseLinearSolver(system.matrix, linear_options);
  GS_RETURN_IF_ERROR(choice.status());
  const LinearSolverType type = choice->type;
  if (choice->analyzed) {
    GS_VLOG(1, "solver choice: CHOLMOD factor %.3g nonzeros, %.3g flops; PCG estimate %.3g "
            "flops (%s crossover) -> %s", choice->factor_nonzeros, choice->factor_flops,
            choice->pcg_cost, linear_options.eliminated_features ? "landmark" : "pose-graph",
            LinearSolverName(type));
  }
  summary->linear_solver_used = type;
  ReducedSystemSolver solver(type, linear_options);
  // The PCG's forcing term, warm start and forest of the interrupted solve.
  if (resume != nullptr) GS_RETURN_IF_ERROR(solver.RestoreState(resume->pcg, system.matrix));

  // The candidate store holds planar points (SolverOptions is shared with the
  // 3-D solver, which keeps its candidates in memory).
  BasicCandidateStore<typename Space::Point>* candidate_store = nullptr;
  if constexpr (std::is_same_v<Space, Space2d>) candidate_store = options.candidate_store;
  ChunkedSpace<Space> space(context, layout, &screening.kept, options.pose_kernels, problem,
                            &system, &solver, &summary->excluded, options.fused_chunk_pass,
                            candidate_store);
  // The first iteration's reduction (at the lambda RunLevenbergMarquardt
  // starts with) gives the initial chi2 of the observations too: one pass
  // instead of two before the first solve (fused schedule; --two-pass keeps
  // its two passes in every iteration).
  double observations_chi2 = 0.0;
  const bool iterates = resume == nullptr ? options.max_iterations >= 1
                                          : !resume->converged &&
                                                resume->iterations + 1 <= options.max_iterations;
  const double first_radius = resume != nullptr ? resume->trust_region_radius
                                                : options.initial_trust_region_radius;
  if (!iterates || !options.fused_chunk_pass ||
      !space.ReduceAhead(1.0 / first_radius, &observations_chi2).ok()) {
    GS_RETURN_IF_ERROR(
        ObservationsChi2(context, problem->poses, problem->features, &observations_chi2));
  }
  const double chi2 =
      PoseFactorsChi2(*problem, problem->poses, options.pose_kernels) + observations_chi2;
  return RunLevenbergMarquardt(options, chi2, resume, checkpoint_callback, start, &space,
                               summary);
}

template Status SolveChunked<Space2d>(const SolverOptions&, const ChunkSource&, Problem2d*,
                                      SolverSummary*, const SolverCheckpoint*,
                                      const std::function<Status(const SolverCheckpoint&)>&);
template Status SolveChunked<Space3d>(const SolverOptions&, const ChunkSource3d&, Problem3d*,
                                      SolverSummary*, const CheckpointOf<Space3d>*,
                                      const std::function<Status(const CheckpointOf<Space3d>&)>&);

}  // namespace graphslam::core::internal
