// SolveChunkedWith: the body of SolveChunked (core/internal/chunked_solve.h)
// as a template on a Ranks policy, so that the one-process solve and the
// solve over MPI ranks (core/distributed/) run the very same setup, passes and
// Levenberg-Marquardt space. The one-process policy is SingleProcess
// (core/internal/single_process.h). A Ranks policy provides:
//
//   using LinearSolver;   // Solve(lambda, D, &system, &x, &iterations, chi2):
//                         //   solves (S + lambda diag(D)) x = rhs; StepResult,
//                         //   SaveState, RestoreState as ReducedSystemSolver
//   bool AddsPoseFactors();               // this process linearizes the pose-only
//                                         // factors (exactly one process does)
//   Status Agree(Status);                 // the status every process shares: its
//                                         // own error, or that of another one
//   void SumSystem(ReducedSystem*);       // gradient, hessian_diagonal, chi2
//                                         // summed over processes (matrix and
//                                         // rhs stay partial: the solver sums them)
//   void SumRecovery(RecoveryResult*);    // the recovery's sums
//   void SumScreening(ScreeningResult*);  // the feature partition of all chunks
//   void SumChi2(double*);
//   StatusOr<unique_ptr<LinearSolver>> MakeLinearSolver(pattern, options, summary);
//
// Each process passes only its own chunks; everything the Levenberg-Marquardt
// control (core/levenberg_marquardt.h) reads is summed before it reads it, so
// every process takes the same decisions. With SingleProcess every hook is
// the identity and the solve is the one-process one, bit for bit.
//
// THREAD SAFETY and ALLOCATION: as SolveGraphSlam.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <optional>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/anderson_acceleration.h"
#include "core/block_sparse_matrix.h"
#include "core/candidate_store.h"
#include "core/chunk_passes.h"
#include "core/internal/chunked_solve.h"
#include "core/levenberg_marquardt.h"
#include "core/logging.h"
#include "core/pose_factors.h"
#include "core/reduced_system_solver.h"
#include "core/unknown_layout.h"

namespace graphslam::core::internal {
namespace chunked_solve_detail {

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
template <class Space, class Ranks>
class ChunkedSpace {
 public:
  using Checkpoint = CheckpointOf<Space>;
  static constexpr const char* kName = Space::kName;
  using Pose = typename Space::Pose;
  using Point = typename Space::Point;

  // fused: one RecoverAndReducePass per accepted iteration (see TryStep).
  // anderson_depth > 0: AcceleratedStepChi2 extrapolates the pose steps (a
  // pose graph only: no observations, so the candidate's chi2 is the pose
  // factors' alone).
  // candidate_store (optional): the step's candidate features go there
  // instead of into an array of one per feature (core/candidate_store.h).
  // kept and excluded are lent to the checkpoint too (LendState), so they
  // are held by non-const reference.
  ChunkedSpace(const BasicPassContext<Space>& context, const UnknownLayout& layout,
               std::vector<uint8_t>* kept, const PoseFactorKernels& pose_kernels,
               typename Space::Problem* problem, ReducedSystem* system,
               typename Ranks::LinearSolver* solver, std::vector<uint8_t>* excluded, bool fused,
               BasicCandidateStore<Point>* candidate_store, Ranks* ranks, int anderson_depth,
               bool pose_graph)
      : context_(context), layout_(layout), kept_(*kept), pose_kernels_(pose_kernels),
        problem_(*problem), system_(*system), solver_(*solver), excluded_(*excluded),
        fused_(fused), candidate_store_(candidate_store), ranks_(*ranks),
        anderson_(anderson_depth), accelerates_(anderson_depth > 0), pose_graph_(pose_graph) {}

  bool AcceleratesSteps() const { return accelerates_; }
  // A rejected step's line search costs one pass over the chunks and saves
  // the passes of further rejections; a pose graph has no such pass to save
  // (and its steps are accelerated instead).
  bool SearchesLines() const { return !pose_graph_; }

  // After an accepted TryStep: *chi2 at x (+) v, v the Anderson extrapolation
  // of its pose step; *computed = false (chi2 untouched) without a history,
  // or when the step is below kAndersonStepRatio times the last accepted
  // one: the plain iteration converges fast there (quadratically near a
  // minimum: intel, M3500, city10000 and sphere2500 shrink their steps by
  // 0.01-0.23 in their last iterations), and evaluating the extrapolation at
  // every accepted step cost 3.8 % of M3500's instructions to lose to the
  // plain step each time. torus3D's steps shrink by 0.3-0.98 (0.5 as the
  // bound cost it 8 iterations of 31).
  Status AcceleratedStepChi2(bool* computed, double* chi2) {
    const double step_norm = pose_step_.norm();
    const bool slow = step_norm >= kAndersonStepRatio * last_step_norm_;
    last_step_norm_ = step_norm;
    taken_accelerated_ = false;
    if (!slow) {
      anderson_.Observe(pose_step_);
      *computed = false;
      return Status::Ok();
    }
    *computed = anderson_.Extrapolate(pose_step_, &accelerated_step_);
    if (!*computed) return Status::Ok();
    accelerated_poses_ = ApplyPoseStep<Space>(problem_.poses, layout_, accelerated_step_);
    *chi2 = PoseFactorsChi2(problem_, accelerated_poses_, pose_kernels_);
    *computed = std::isfinite(*chi2);
    return Status::Ok();
  }

  // The accelerated state becomes the candidate Accept() takes. The fused
  // pass reduced at the plain candidate: that system is dropped.
  void TakeAcceleratedStep() {
    candidate_poses_.swap(accelerated_poses_);
    speculation_built_ = false;
    taken_accelerated_ = true;
  }

  // After a rejected TryStep: *chi2 at x (+) t d, d the whole step (poses
  // and features, the features moved along their straight line to the
  // candidate); that state becomes the candidate Accept() takes. One pass
  // over the chunks: with the candidates in memory a chi2 pass; with a
  // candidate store, which holds the candidates but not x beside them, a
  // recovery of the same step that scales each candidate before its chi2
  // and writes the scaled ones to the store (the same numbers as in memory,
  // bit for bit). *computed = false (nothing changed) unless SearchesLines().
  // Fused (next_lambda > 0): the same pass also reduces at x (+) t d with
  // next_lambda into system_, as TryStep's fused pass does at x (+) d
  // (RecoverAndReducePass; in memory a ReducePass, whose chi2 is the sum
  // ObservationsChi2 gives, in the same order); the system is dead by now
  // (the rejected step's was solved). An accepted line step then needs no
  // reduce pass in the next iteration.
  Status ScaledStepChi2(double t, double next_lambda, bool* computed, double* chi2) {
    *computed = false;
    if (!SearchesLines()) return Status::Ok();
    const Eigen::VectorXd step = pose_step_;
    pose_step_ *= t;
    candidate_poses_ = ApplyPoseStep<Space>(problem_.poses, layout_, pose_step_);
    speculation_built_ = false;
    const bool reduce_ahead = fused_ && next_lambda > 0.0;
    if (reduce_ahead) ResetSystem(candidate_poses_, &system_);
    double observations_chi2 = 0.0;
    if (candidate_store_ != nullptr) {
      RecoveryResult recovery;
      const BasicRecoveryInput<Space> input{problem_.poses, problem_.features, step_lambda_,
                                            step,           candidate_poses_,  t};
      GS_RETURN_IF_ERROR(candidate_store_->Begin());
      if (reduce_ahead) {
        Status next_status;
        GS_RETURN_IF_ERROR(ranks_.Agree(
            RecoverAndReducePass<Space>(context_, input, CandidateSinkForThisStep(), &recovery,
                                        {next_lambda, &system_, &next_status})));
        next_status = ranks_.Agree(std::move(next_status));
        if (next_status.ok()) ranks_.SumSystem(&system_);
        speculation_built_ = next_status.ok();
        speculative_lambda_ = next_lambda;
      } else {
        GS_RETURN_IF_ERROR(ranks_.Agree(
            RecoverPass<Space>(context_, input, CandidateSinkForThisStep(), &recovery)));
      }
      GS_RETURN_IF_ERROR(candidate_store_->Finish());
      observations_chi2 = recovery.candidate_chi2;
    } else {
      const std::vector<Point>& features = problem_.features;
      for (size_t g = 0; g < features.size(); ++g) {
        if (!excluded_[g])
          candidate_features_[g] = features[g] + t * (candidate_features_[g] - features[g]);
      }
      // A failed elimination at x (+) t d only loses the reduction: the
      // chi2 comes from the plain pass then.
      const Status reduced =
          reduce_ahead ? ranks_.Agree(ReducePass(context_, candidate_poses_, candidate_features_,
                                                 next_lambda, &system_))
                       : Status::Numerical("not reduced ahead");
      if (reduced.ok()) {
        observations_chi2 = system_.chi2;  // this process's share, as ObservationsChi2's
        ranks_.SumSystem(&system_);
        speculation_built_ = true;
        speculative_lambda_ = next_lambda;
      } else {
        GS_RETURN_IF_ERROR(ranks_.Agree(ObservationsChi2(
            context_, candidate_poses_, candidate_features_, &observations_chi2)));
      }
    }
    ranks_.SumChi2(&observations_chi2);
    *chi2 = PoseFactorsChi2(problem_, candidate_poses_, pose_kernels_) + observations_chi2;
    *computed = std::isfinite(*chi2);
    return Status::Ok();
  }

  // A rejected step: the damping changes, and with it the iteration map.
  void ForgetAcceleration() {
    anderson_.Reset();
    last_step_norm_ = 0.0;
  }

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
    GS_RETURN_IF_ERROR(ranks_.Agree(
        ReducePass(context_, problem_.poses, problem_.features, lambda, &system_)));
    ranks_.SumSystem(&system_);
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
    GS_RETURN_IF_ERROR(ranks_.Agree(
        ReducePass(context_, problem_.poses, problem_.features, lambda, &system_)));
    ranks_.SumSystem(&system_);
    speculation_ready_ = true;
    speculative_lambda_ = lambda;
    *observations_chi2 = system_.chi2;
    return Status::Ok();
  }

  Status TryStep(double lambda, double speculative_lambda, bool /*usable*/, IterationSummary* it,
                 TrialStep* trial) {
    const std::vector<Pose>& poses = problem_.poses;
    damping_ = system_.hessian_diagonal.cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
    speculation_built_ = false;

    // Damp and solve the reduced pose system (Ranks::LinearSolver).
    const Clock::time_point solve_start = Clock::now();
    Status solve_status = solver_.Solve(lambda, damping_, &system_, &pose_step_,
                                        &it->linear_iterations, it->start_chi2);
    trial->ok = solve_status.ok();
    it->solve_seconds = SecondsSince(solve_start);
    const Clock::time_point recover_start = Clock::now();
    if (!trial->ok)
      GS_VLOG(1, "linear solve failed (%s); raising damping", solve_status.ToString().c_str());
    if (trial->ok) {
      // Recover the features and evaluate the candidate; in the same pass,
      // reduce at the candidate for the next iteration when there is one.
      RecoveryResult recovery;
      // The pose factors' chi2 at the candidate: the speculative reduction
      // below sums it while it linearizes them there.
      std::optional<double> candidate_pose_chi2;
      candidate_poses_ = ApplyPoseStep<Space>(poses, layout_, pose_step_);
      CandidateSink<Space> sink = CandidateSinkForThisStep();
      step_lambda_ = lambda;
      const BasicRecoveryInput<Space> input{poses, problem_.features, lambda, pose_step_,
                                            candidate_poses_, 1.0};
      if (candidate_store_ != nullptr) GS_RETURN_IF_ERROR(candidate_store_->Begin());
      if (fused_ && speculative_lambda > 0.0) {
        // Once solved, this linearization's matrix and rhs are dead (a
        // rejected step re-reduces at x from scratch): the next system is
        // reduced into the same buffer. Only g_x is still needed, for the
        // model decrease below.
        step_gradient_.swap(system_.gradient);
        candidate_pose_chi2 = ResetSystem(candidate_poses_, &system_);
        Status next_status;
        GS_RETURN_IF_ERROR(ranks_.Agree(RecoverAndReducePass<Space>(
            context_, input, sink, &recovery, {speculative_lambda, &system_, &next_status})));
        // Built only if every rank built its part.
        next_status = ranks_.Agree(std::move(next_status));
        if (next_status.ok()) ranks_.SumSystem(&system_);
        speculation_built_ = next_status.ok();
        speculative_lambda_ = speculative_lambda;
        if (!next_status.ok())
          GS_VLOG(1, "speculative reduce failed (%s)", next_status.ToString().c_str());
      } else {
        GS_RETURN_IF_ERROR(ranks_.Agree(RecoverPass<Space>(context_, input, sink, &recovery)));
        step_gradient_ = system_.gradient;
      }
      if (candidate_store_ != nullptr) GS_RETURN_IF_ERROR(candidate_store_->Finish());
      ranks_.SumRecovery(&recovery);
      ++it->chunk_passes;
      if (!candidate_pose_chi2.has_value())
        candidate_pose_chi2 = PoseFactorsChi2(problem_, candidate_poses_, pose_kernels_);
      trial->candidate_chi2 = *candidate_pose_chi2 + recovery.candidate_chi2;
      if (LogVerbosity() >= 2) {
        const double pose_chi2 = PoseFactorsChi2(problem_, poses, pose_kernels_);
        GS_VLOG(2, "candidate: pose factors chi2 %.9g -> %.9g, observations %.9g -> %.9g",
                pose_chi2, *candidate_pose_chi2, it->start_chi2 - pose_chi2,
                recovery.candidate_chi2);
      }
      trial->gradient_dot_step = step_gradient_.dot(pose_step_) + recovery.gradient_dot_step;
      trial->model_decrease = -trial->gradient_dot_step +
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
    if (accelerates_) anderson_.Record(taken_accelerated_ ? accelerated_step_ : pose_step_);
    taken_accelerated_ = false;
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
  // ReducePass (or the reduce half of the fused pass) starts from. Returns
  // their chi2 at `poses` (PoseFactorsChi2's sum) when this process adds
  // them, nothing otherwise.
  std::optional<double> ResetSystem(const std::vector<Pose>& poses,
                                    ReducedSystem* system) const {
    const int num_rows = system->matrix.num_rows();
    system->matrix.SetZero();
    system->rhs.setZero(num_rows);
    system->gradient.setZero(num_rows);
    system->hessian_diagonal.setZero(num_rows);
    system->chi2 = 0.0;
    std::optional<double> pose_chi2;
    if (ranks_.AddsPoseFactors()) {
      pose_chi2 = LinearizePoseFactors(problem_, poses, layout_, &system->matrix,
                                       &system->gradient, &system->hessian_diagonal,
                                       pose_kernels_);
    }
    system->rhs -= system->gradient;
    return pose_chi2;
  }

  const BasicPassContext<Space>& context_;
  const UnknownLayout& layout_;
  std::vector<uint8_t>& kept_;
  const PoseFactorKernels& pose_kernels_;
  typename Space::Problem& problem_;
  ReducedSystem& system_;
  typename Ranks::LinearSolver& solver_;
  std::vector<uint8_t>& excluded_;
  const bool fused_;
  BasicCandidateStore<Point>* const candidate_store_;  // may be null
  Ranks& ranks_;
  static constexpr double kAndersonStepRatio = 0.25;
  AndersonAcceleration anderson_;
  const bool accelerates_;
  const bool pose_graph_;
  double last_step_norm_ = 0.0;  // of the last accepted plain step (0: none)
  bool taken_accelerated_ = false;
  Eigen::VectorXd accelerated_step_;
  std::vector<Pose> accelerated_poses_;
  Eigen::VectorXd step_gradient_;  // g_x of the linearization the last step solved
  Eigen::VectorXd damping_;
  Eigen::VectorXd pose_step_;
  double step_lambda_ = 0.0;  // the damping pose_step_ was solved with
  std::vector<Pose> candidate_poses_;
  std::vector<Point> candidate_features_;
  // Speculation: system_ holds the reduction at the last candidate (built by
  // the last TryStep); ready once that step was accepted.
  bool speculation_built_ = false;
  bool speculation_ready_ = false;
  double speculative_lambda_ = 0.0;
};

// The steps of SolveChunkedWith, in order.

template <class Space>
BasicPassContext<Space> MakePassContext(const SolverOptions& options,
                                        const BasicChunkSource<typename Space::Observation>& chunks,
                                        const UnknownLayout& layout) {
  BasicPassContext<Space> context;
  context.chunks = &chunks;
  context.layout = &layout;
  context.max_in_flight = options.max_chunks_in_flight;
  context.progress = options.progress;
  context.kernel = options.observation_kernel;
  return context;
}

// A resume keeps the checkpoint's partition of the features, not one
// recomputed at the resumed state: the continued solve must be the
// interrupted one. Also moves the checkpoint's estimates into *problem.
template <class Space>
Status AdoptCheckpoint(const CheckpointOf<Space>& resume, typename Space::Problem* problem,
                       ScreeningResult* screening, SolverSummary* summary) {
  // A resume whose feature array is empty while the problem has features:
  // the caller moved the checkpoint's estimates into problem->features
  // already (SolverOptions::resume_from), so no second copy is held.
  const bool features_in_problem = resume.features.empty() && !problem->features.empty();
  if (resume.poses.size() != problem->poses.size() ||
      (!features_in_problem && resume.features.size() != problem->features.size()) ||
      resume.excluded.size() != problem->features.size() ||
      resume.kept.size() != problem->features.size()) {
    return Status::InvalidArgument(
        "checkpoint does not match the problem: " + std::to_string(resume.poses.size()) +
        " poses and " + std::to_string(resume.features.size()) + " features, expected " +
        std::to_string(problem->poses.size()) + " and " +
        std::to_string(problem->features.size()));
  }
  const int64_t unobserved = screening->unobserved;
  screening->excluded = resume.excluded;
  screening->kept = resume.kept;
  screening->kept_count = std::count(screening->kept.begin(), screening->kept.end(), 1);
  screening->excluded_not_positive_definite =
      std::count(screening->excluded.begin(), screening->excluded.end(), 1) - unobserved;
  problem->poses = resume.poses;
  if (!features_in_problem) problem->features = resume.features;
  summary->resumed_from_iteration = resume.iterations;
  return Status::Ok();
}

// The screening's counts into *summary; its excluded flags are moved there
// (one byte per feature; the screening's copy is dead).
inline void RecordScreening(int64_t num_features, ScreeningResult* screening,
                            SolverSummary* summary) {
  summary->kept_features = screening->kept_count;
  summary->excluded_features = screening->excluded_not_positive_definite;
  summary->unobserved_features = screening->unobserved;
  summary->observations_used = screening->observations;
  summary->eliminated_features = num_features - screening->excluded_not_positive_definite -
                                 screening->unobserved - screening->kept_count;
  if (screening->excluded_not_positive_definite > 0) {
    GS_LOG(WARNING,
           "%lld features have information that is not positive definite (too few or "
           "degenerate observations); they are kept out of the solve",
           static_cast<long long>(screening->excluded_not_positive_definite));
  }
  summary->excluded = std::move(screening->excluded);
}

// The reduced matrix's pattern: pose-only factors plus co-observing poses
// (collected by the screening, or in a pass of its own on a resume).
template <class Space, class Ranks>
Status BuildReducedMatrix(const BasicPassContext<Space>& context,
                          const typename Space::Problem& problem, const UnknownLayout& layout,
                          ScreenedPattern* screened_pattern, bool resumed, Ranks* ranks,
                          ReducedSystem* system, SolverSummary* summary) {
  std::vector<std::pair<int, int>> pairs;
  if (ranks->AddsPoseFactors()) AppendPoseFactorPattern(problem, layout, &pairs);
  if (!resumed) {
    AppendScreenedPattern(layout, screened_pattern, &pairs);
  } else {
    GS_RETURN_IF_ERROR(ranks->Agree(CollectReducedPattern(context, &pairs)));
  }
  system->matrix =
      BlockSparseMatrix::FromPattern(Space::kPoseDim, layout.num_blocks(), std::move(pairs));
  summary->reduced_nonzero_blocks = system->matrix.num_nonzero_blocks();
  GS_VLOG(1, "reduced system: %d poses, %lld stored blocks; product: %d ranges, %lld accumulator rows, "
          "%lld far blocks", system->matrix.num_block_rows(),
          static_cast<long long>(system->matrix.num_stored_blocks()),
          system->matrix.num_product_ranges(), static_cast<long long>(system->matrix.num_accumulator_rows()),
          static_cast<long long>(system->matrix.num_far_blocks()));
  return Status::Ok();
}

// The reduced system's solver options (core/reduced_system_solver.h): kAuto
// picks CHOLMOD or PCG from CHOLMOD's symbolic analysis of the pattern.
inline ReducedSystemSolverOptions LinearSolverOptions(const SolverOptions& options,
                                                      bool eliminated_features) {
  ReducedSystemSolverOptions linear_options;
  linear_options.type = options.linear_solver;
  linear_options.preconditioner = options.preconditioner;
  linear_options.pcg_max_iterations = options.pcg_max_iterations;
  linear_options.pcg_relative_tolerance = options.pcg_relative_tolerance;
  linear_options.forcing_sequence = options.pcg_forcing_sequence;
  linear_options.eta_max = options.pcg_eta_max;
  // Landmark problems only (core/graphslam_solver.h, pcg_truncation).
  linear_options.truncation =
      eliminated_features ? options.pcg_truncation * options.function_tolerance : 0.0;
  linear_options.warm_start = options.pcg_warm_start;
  linear_options.deflation_poses = options.pcg_deflation_poses;
  linear_options.max_analysis_unknowns = options.auto_cholmod_max_unknowns;
  linear_options.max_factor_bytes = options.auto_cholmod_max_factor_bytes;
  linear_options.cholmod_factor_check = options.cholmod_factor_check;
  linear_options.eliminated_features = eliminated_features;
  return linear_options;
}

// The options RunLevenbergMarquardt runs with: a trust-region radius of 0 is
// the linear solver's default (core/graphslam_solver.h).
inline SolverOptions ResolvedOptions(const SolverOptions& options,
                                     LinearSolverType linear_solver_used) {
  SolverOptions resolved = options;
  if (resolved.initial_trust_region_radius == 0)
    resolved.initial_trust_region_radius = linear_solver_used == LinearSolverType::kCholmod
                                               ? kDirectInitialTrustRegion
                                               : kIterativeInitialTrustRegion;
  return resolved;
}

// chi2 of the observations at the start. The first iteration's reduction (at
// the lambda RunLevenbergMarquardt starts with) gives it too: one pass
// instead of two before the first solve (fused schedule; --two-pass keeps its
// two passes in every iteration).
template <class Space, class Ranks>
Status InitialObservationsChi2(const SolverOptions& options, const CheckpointOf<Space>* resume,
                               double first_radius, const BasicPassContext<Space>& context,
                               const typename Space::Problem& problem,
                               ChunkedSpace<Space, Ranks>* space, Ranks* ranks, double* chi2) {
  *chi2 = 0.0;
  const bool iterates = resume == nullptr ? options.max_iterations >= 1
                                          : !resume->converged &&
                                                resume->iterations + 1 <= options.max_iterations;
  if (iterates && options.fused_chunk_pass && space->ReduceAhead(1.0 / first_radius, chi2).ok())
    return Status::Ok();
  GS_RETURN_IF_ERROR(
      ranks->Agree(ObservationsChi2(context, problem.poses, problem.features, chi2)));
  ranks->SumChi2(chi2);
  return Status::Ok();
}

}  // namespace chunked_solve_detail

template <class Space, class Ranks>
Status SolveChunkedWith(
    const SolverOptions& options, const BasicChunkSource<typename Space::Observation>& chunks,
    typename Space::Problem* problem, SolverSummary* summary, const CheckpointOf<Space>* resume,
    const std::function<Status(const CheckpointOf<Space>&)>& checkpoint_callback,
    Ranks* ranks) {
  namespace detail = chunked_solve_detail;
  GS_RETURN_IF_ERROR(options.Validate());
  const SolverClock::time_point start = SolverClock::now();
  *summary = SolverSummary();

  UnknownLayout layout = UnknownLayout::FromProblem(*problem);
  summary->unknown_poses = layout.num_unknown_poses;
  BasicPassContext<Space> context = detail::MakePassContext<Space>(options, chunks, layout);

  // 1. Which features can be eliminated (positive definite information), and
  //    in the same pass the pattern of S under that partition.
  ScreeningResult screening;
  ScreenedPattern screened_pattern;
  GS_RETURN_IF_ERROR(ranks->Agree(ScreenFeatures(context, problem->poses, problem->features,
                                                 options.max_eliminated_observations, &screening,
                                                 resume == nullptr ? &screened_pattern : nullptr)));
  ranks->SumScreening(&screening);
  if (resume != nullptr)
    GS_RETURN_IF_ERROR(detail::AdoptCheckpoint<Space>(*resume, problem, &screening, summary));
  layout.KeepFeatures(screening.kept);
  detail::RecordScreening(problem->num_features(), &screening, summary);
  context.excluded = &summary->excluded;

  // 2. The reduced system and its solver.
  ReducedSystem system;
  GS_RETURN_IF_ERROR(detail::BuildReducedMatrix(context, *problem, layout, &screened_pattern,
                                                resume != nullptr, ranks, &system, summary));
  const ReducedSystemSolverOptions linear_options =
      detail::LinearSolverOptions(options, summary->eliminated_features > 0);
  GS_RETURN_IF_ERROR(linear_options.Validate());
  StatusOr<std::unique_ptr<typename Ranks::LinearSolver>> solver =
      ranks->MakeLinearSolver(system.matrix, linear_options, summary);
  GS_RETURN_IF_ERROR(solver.status());
  // The PCG's forcing term, warm start and forest of the interrupted solve.
  if (resume != nullptr)
    GS_RETURN_IF_ERROR((*solver)->RestoreState(resume->pcg, system.matrix));

  // 3. Levenberg-Marquardt over the chunk passes. The candidate store holds
  //    planar points (SolverOptions is shared with the 3-D solver, which
  //    keeps its candidates in memory).
  BasicCandidateStore<typename Space::Point>* candidate_store = nullptr;
  if constexpr (std::is_same_v<Space, Space2d>) candidate_store = options.candidate_store;
  // Anderson acceleration: pose graphs only, and not with checkpoints (its
  // history is not in them; core/graphslam_solver.h).
  const bool pose_graph = summary->observations_used == 0;
  const int anderson_depth =
      pose_graph && resume == nullptr && !checkpoint_callback ? options.anderson_depth : 0;
  detail::ChunkedSpace<Space, Ranks> space(context, layout, &screening.kept, options.pose_kernels,
                                           problem, &system, solver->get(), &summary->excluded,
                                           options.fused_chunk_pass, candidate_store, ranks,
                                           anderson_depth, pose_graph);
  const SolverOptions resolved = detail::ResolvedOptions(options, summary->linear_solver_used);
  const double first_radius = resume != nullptr ? resume->trust_region_radius
                                                : resolved.initial_trust_region_radius;
  double observations_chi2 = 0.0;
  GS_RETURN_IF_ERROR(detail::InitialObservationsChi2(options, resume, first_radius, context,
                                                     *problem, &space, ranks,
                                                     &observations_chi2));
  const double chi2 =
      PoseFactorsChi2(*problem, problem->poses, options.pose_kernels) + observations_chi2;
  return RunLevenbergMarquardt(resolved, chi2, resume, checkpoint_callback, start, &space,
                               summary);
}

}  // namespace graphslam::core::internal
