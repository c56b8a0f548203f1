// RunLevenbergMarquardt: the Levenberg-Marquardt control of the GraphSLAM loop
// (paper Table 5), written once for the planar (core/graphslam_solver.h) and
// the 3-D (core/graphslam_solver_3d.h) solvers. The problem "space" (a policy
// class; the one in use is ChunkedSpace of core/internal/chunked_solve.cc,
// a template on core/problem_space.h) owns the state, the linearization, the
// reduced solve and the recovery, with its block sizes (3 / 2 in the plane,
// 6 / 3 in 3-D) fixed at compile time in its hot loops; this file owns every
// decision:
//
//   lambda = 1 / mu (mu: trust region radius)
//   gradient test      max |g| <= gradient_tolerance           -> converged
//   step quality       rho = (chi2 - chi2') / (-g^T d + lambda d^T D d)
//   accept             rho > min_relative_decrease (and a finite chi2')
//   Nielsen update     success: mu /= max(1/3, 1 - (2 rho - 1)^3) (<= mu_max), v = 2
//                      failure: mu /= v, v *= 2
//   model fit so far   while every step has been accepted with rho >=
//                      kSpeculationRho: mu *= kFitRadiusGrowth (<= mu_max)
//   convergence        (chi2 - chi2') / chi2 < function_tolerance, or
//                      |d| <= parameter_tolerance (|state| + parameter_tolerance),
//                      or mu < min_trust_region_radius (no further decrease),
//                      or the next step's decrease extrapolated below
//                      function_tolerance (kMaxExtrapolatedContraction),
//                      or a rejected step whose model decrease is below
//                      max(model_tolerance, function_tolerance) x chi2
//                      (ModelDecreaseBelowTolerance; no line search then)
//   acceleration       (a space that AcceleratesSteps, a pose graph) after an
//                      accepted step: its Anderson extrapolation replaces it
//                      when that lowers chi2 further (the safeguard); rho and
//                      the radius stay those of the plain step, the chi2
//                      decrease of the convergence test is the one taken;
//                      a rejected step forgets the history
//   line search        a rejected step of a space that SearchesLines (a
//                      problem with observations, where it saves passes
//                      over the chunks; not pose graphs) with finite chi2'
//                      and model decrease at least the tolerance of
//                      ModelDecreaseBelowTolerance:
//                      chi2 is evaluated at
//                      x (+) t d, t the minimizer of the quadratic through
//                      chi2(0), its slope 2 g^T d and chi2(1), kept in
//                      [kMinLineStep, kMaxLineStep]; accepted when
//                      (chi2 - chi2(t)) / m(t) > min_relative_decrease,
//                      m(t) = -2 t g^T d + t^2 (2 g^T d + m(1)) the model
//                      decrease along the step; the radius shrinks as for
//                      the rejected step (see LineSearchFraction)
//   abandon            rho < abandon_below_rho (if > 0) on a step whose model
//                      decrease is > 1e-3 chi2                          -> stop,
//                      termination "abandoned", not converged (the probe of
//                      --initialization auto: the start is not in the basin)
//   after every iteration: summary, iteration callback, progress, and the
//   checkpoint (control state + the space's state) for a bit-identical resume;
//   before the first, the start's checkpoint (iteration 0).
//
// A Space provides:
//   using Checkpoint = BasicSolverCheckpoint<Pose, Point>;
//   static constexpr const char* kName;  // log prefix
//   // Linearize and reduce about the current state with damping lambda; sets
//   // it->gradient_max_norm. A non-OK Status is fatal; *usable = false (e.g.
//   // a feature block that is not positive definite) asks for more damping.
//   Status Linearize(double lambda, IterationSummary* it, bool* usable);
//   // Damp, solve, recover and evaluate the candidate; sets it->step_norm,
//   // linear_iterations, solve_seconds, recover_seconds. trial->ok = false
//   // (a failed linear solve) asks for more damping. speculative_lambda > 0
//   // is the lambda of the next iteration if this step is accepted with
//   // rho >= kSpeculationRho: a space may linearize and reduce at the
//   // candidate with it during its recovery (the chunked space's one-pass
//   // iteration) and reuse that in the next Linearize if Accept() was called
//   // and the lambda it gets is that very number. It is 0 (do not speculate)
//   // on the last iteration and after a rejected step: a wasted speculation
//   // costs the eliminations of a reduction, a hit saves a pass.
//   Status TryStep(double lambda, double speculative_lambda, bool usable,
//                  IterationSummary* it, TrialStep* trial);   // it->start_chi2 is set
//   void StepResult(bool accepted);          // after every computed step
//   // After a rejected step: chi2 at x (+) t d; *computed = false when the
//   // space cannot evaluate it. When computed, that state is the candidate
//   // Accept() takes. Asked only when SearchesLines(). next_lambda > 0 is
//   // the next iteration's lambda (the radius after the rejection, known
//   // before rho(t)): as with TryStep's speculative_lambda, a space may
//   // reduce at x (+) t d with it in the same pass and reuse that system if
//   // the line step is accepted (then the lambda is that very number).
//   bool SearchesLines() const;
//   Status ScaledStepChi2(double t, double next_lambda, bool* computed, double* chi2);
//   bool AcceleratesSteps() const;
//   // After an accepted step (before Accept): chi2 of the extrapolated state;
//   // *computed = false when there is none. TakeAcceleratedStep makes it the
//   // candidate Accept() takes; ForgetAcceleration after a rejected step.
//   Status AcceleratedStepChi2(bool* computed, double* chi2);
//   void TakeAcceleratedStep();
//   void ForgetAcceleration();
//   Status Accept();                         // the candidate becomes the state
//   void LendState(Checkpoint* checkpoint);    // moves poses, features, excluded,
//   void ReturnState(Checkpoint* checkpoint);  // kept in; ReturnState moves them back
//
// The state is lent to the checkpoint (moved, not copied) for the callback's
// duration: at 10^8 features a copy of the feature estimates is ~0.7 GB of
// peak memory (docs/benchmarks.md, the 10^8 run).
//
// THREAD SAFETY: one call per space. ALLOCATION: one IterationSummary per
// iteration in the summary; the checkpoint's solver state per iteration when
// asked (the space's vectors are moved, not copied).
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>

#include "core/graphslam_solver.h"
#include "core/logging.h"
#include "core/status.h"

namespace graphslam::core {

// (1 + cbrt(2/3)) / 2: 1 - (2 rho - 1)^3 <= 1/3 from here on.
inline constexpr double kSpeculationRho = 0.9368;

// While the quadratic model has fit every step of the solve (each accepted
// with rho >= kSpeculationRho, from the first on), the solve is in
// Gauss-Newton's regime and the damping only holds back the weakest modes:
// parking-garage's floors take 7 iterations with the radius growing 3x per
// step, 5 with 10x. A solve that starts outside that regime (torus3D's
// first steps are rejected) keeps Nielsen's rule throughout.
inline constexpr double kFitRadiusGrowth = 10.0;

// Extrapolated convergence: three consecutive plain (not accelerated)
// accepted steps whose model fit (rho >= kSpeculationRho), with chi2
// decreases d_2, d_1, d, each at most kMaxExtrapolatedContraction times the
// one before: the iteration contracts superlinearly, and the next step's
// decrease is estimated at d (d / d_1) (exact for linear convergence at a
// constant rate, above Gauss-Newton's quadratic one). Below
// function_tolerance x chi2 the solve stops there, converged: the next iteration
// would only have confirmed it (intel's 5th and M3500's 6th iteration
// lowered chi2 by 2e-10 and 5e-9 of it). torus3D's irregular decreases
// (steps shrinking by 0.3-0.98, Anderson-accelerated) never qualify. Pose
// graphs only (a space that AcceleratesSteps): with features eliminated the
// estimate fell short (Victoria Park from its file: 3.5e-6 of chi2 left
// where 1e-6 was estimated). Not with checkpoints or a resume, which do not
// hold d_2 and d_1.
inline constexpr double kMaxExtrapolatedContraction = 0.1;

// d_2, d_1, d as above (0 for a step that does not qualify); chi2 after d.
inline bool ExtrapolatedDecreaseBelow(double d_2, double d_1, double d, double chi2,
                                      double function_tolerance) {
  return d_2 > 0.0 && d_1 > 0.0 && d_1 <= kMaxExtrapolatedContraction * d_2 &&
         d <= kMaxExtrapolatedContraction * d_1 && d * (d / d_1) < function_tolerance * chi2;
}

// The trust region radius after a step accepted with ratio rho: Nielsen's
// radius / max(1/3, 1 - (2 rho - 1)^3), or radius * kFitRadiusGrowth when
// the model has fit every step so far and this one too, at most
// max_trust_region_radius. For every rho >= kSpeculationRho the result is
// one and the same double (Nielsen's max is 1/3 itself there): the value
// RadiusAfterAcceptedStep(radius, 1.0, fit_so_far, ...) a space can
// speculate on before rho is known.
inline double RadiusAfterAcceptedStep(double radius, double rho, bool fit_so_far,
                                      const SolverOptions& options) {
  if (fit_so_far && rho >= kSpeculationRho)
    return std::min(radius * kFitRadiusGrowth, options.max_trust_region_radius);
  const double factor = 1.0 - std::pow(2.0 * rho - 1.0, 3);
  return std::min(radius / std::max(1.0 / 3.0, factor), options.max_trust_region_radius);
}

// Whether a solve that completed `iterations` iterations and holds `radius`
// had the model fit every step: exactly then its radius is the initial one
// grown kFitRadiusGrowth times per iteration (a resume recovers the flag from
// the checkpoint's radius; where the other history meets the same capped
// radius, both rules give the same radius from there on).
inline bool ModelFitEveryStep(int iterations, double radius, const SolverOptions& options) {
  double fit_radius = options.initial_trust_region_radius;
  for (int k = 0; k < iterations; ++k)
    fit_radius = std::min(fit_radius * kFitRadiusGrowth, options.max_trust_region_radius);
  return fit_radius == radius;
}

// What the space reports about one trial step.
struct TrialStep {
  bool ok = false;  // a step was computed (else more damping)
  double candidate_chi2 = std::numeric_limits<double>::infinity();
  double model_decrease = 0.0;      // -g^T d + lambda d^T D d
  double gradient_dot_step = 0.0;   // g^T d: chi2's slope along d is 2 g^T d
  double state_norm_squared = 0.0;  // |state|^2 at the linearization point
};

using SolverClock = std::chrono::steady_clock;

inline double SecondsSince(SolverClock::time_point start) {
  return std::chrono::duration<double>(SolverClock::now() - start).count();
}

// After an accepted step: the space's accelerated step (Anderson mixing of
// the last accepted steps) replaces it when its chi2 is lower. A rejected
// step ends the history the acceleration mixes.
template <class Space>
Status MaybeAccelerate(Space* space, double* candidate_chi2, IterationSummary* it) {
  if (!space->AcceleratesSteps()) return Status::Ok();
  if (!it->accepted) {
    space->ForgetAcceleration();
    return Status::Ok();
  }
  bool computed = false;
  double accelerated_chi2 = 0.0;
  GS_RETURN_IF_ERROR(space->AcceleratedStepChi2(&computed, &accelerated_chi2));
  if (computed && accelerated_chi2 < *candidate_chi2) {
    space->TakeAcceleratedStep();
    *candidate_chi2 = accelerated_chi2;
    it->candidate_chi2 = accelerated_chi2;
    it->accelerated = true;
  }
  return Status::Ok();
}

// The controller's state between iterations (what a checkpoint keeps, plus
// the history the radius rule and the extrapolated stop look at).
struct LevenbergMarquardtState {
  double chi2 = 0.0;
  double radius = 0.0;
  double decrease_factor = 2.0;
  bool fit_so_far = true;  // every step accepted with rho >= kSpeculationRho
  // The chi2 decreases of the last two steps, each 0 unless it was a plain
  // step accepted with rho >= kSpeculationRho (the last one first).
  double decrease_1 = 0.0;
  double decrease_2 = 0.0;
};

// Takes over an interrupted solve's controller state. The checkpoint's chi2,
// not a recomputation: acceptance decisions must see the very number the
// interrupted solve saw.
template <class Checkpoint>
void RestoreFromCheckpoint(const Checkpoint& resume, const SolverOptions& options,
                           LevenbergMarquardtState* state, SolverSummary* summary) {
  state->chi2 = resume.chi2;
  summary->final_chi2 = resume.chi2;
  summary->initial_chi2 = resume.initial_chi2;
  state->radius = resume.trust_region_radius;
  state->decrease_factor = resume.decrease_factor;
  state->fit_so_far = ModelFitEveryStep(resume.iterations, state->radius, options);
  summary->iterations = resume.iterations;
  summary->resumed_from_iteration = resume.iterations;
  if (resume.converged) {
    summary->converged = true;
    summary->termination = resume.termination;
  }
}

// Step 4 once the space has taken an accepted step (candidate_chi2 its chi2):
// the trust region grows, and the tests of convergence. Returns whether the
// solve has converged (summary->termination says by which test).
inline bool UpdateAfterAcceptedStep(const SolverOptions& options, bool extrapolate,
                                    const TrialStep& trial, double candidate_chi2,
                                    const IterationSummary& it, LevenbergMarquardtState* state,
                                    SolverSummary* summary) {
  const double relative_change = (state->chi2 - candidate_chi2) / std::max(state->chi2, 1e-300);
  state->chi2 = candidate_chi2;
  state->radius =
      RadiusAfterAcceptedStep(state->radius, it.relative_decrease, state->fit_so_far, options);
  state->fit_so_far = state->fit_so_far && it.relative_decrease >= kSpeculationRho;
  state->decrease_factor = 2.0;
  bool converged = false;
  if (relative_change < options.function_tolerance) {
    summary->termination = "function_tolerance";
    converged = true;
  } else if (it.step_norm <= options.parameter_tolerance *
                                 (std::sqrt(trial.state_norm_squared) +
                                  options.parameter_tolerance)) {
    summary->termination = "parameter_tolerance";
    converged = true;
  }
  const double decrease = it.relative_decrease >= kSpeculationRho && !it.accelerated
                              ? it.start_chi2 - state->chi2
                              : 0.0;
  if (!converged && extrapolate && decrease > 0.0 &&
      ExtrapolatedDecreaseBelow(state->decrease_2, state->decrease_1, decrease, state->chi2,
                                options.function_tolerance)) {
    summary->termination = "function_tolerance";
    converged = true;
  }
  state->decrease_2 = state->decrease_1;
  state->decrease_1 = decrease;
  return converged;
}

// Step 4 after a rejected step: the trust region shrinks, faster each time.
inline void UpdateAfterRejectedStep(LevenbergMarquardtState* state) {
  state->decrease_2 = state->decrease_1 = 0.0;
  state->fit_so_far = false;
  state->radius /= state->decrease_factor;
  state->decrease_factor *= 2.0;
}

// A line step accepted after the full step was rejected (the radius has
// already shrunk as for that step, UpdateAfterRejectedStep): the state
// moves; the next rejection halves the radius again. Returns whether the
// solve has converged by the function tolerance.
inline bool UpdateAfterLineStep(const SolverOptions& options, double line_chi2,
                                LevenbergMarquardtState* state, SolverSummary* summary) {
  const double relative_change = (state->chi2 - line_chi2) / std::max(state->chi2, 1e-300);
  state->chi2 = line_chi2;
  state->decrease_factor = 2.0;
  if (relative_change >= options.function_tolerance) return false;
  summary->termination = "function_tolerance";
  return true;
}

// The tolerance of ModelDecreaseBelowTolerance, relative to chi2.
inline double ModelStopTolerance(const SolverOptions& options) {
  return std::max(options.model_tolerance, options.function_tolerance);
}

// The stop on the model, after a rejected step (sets the termination and
// returns true when it fires). The model decrease
// m(lambda) = -g^T d + lambda d^T D d of the Levenberg-Marquardt step is the
// quadratic model's estimate of the chi2 still to gain: at lambda = 0 it is
// g^T H^-1 g, chi2 - chi2(optimum) to second order (the Newton decrement);
// damping only lowers it, so a heavily damped step's m understates what is
// left. It says more than an accepted step's decrease where the iteration
// converges slowly: along a weakly determined mode whose cost the model
// underestimates at full length, every full step is rejected and the line
// step gains a small share of m, so the decreases shrink slowly and the
// function tolerance, which looks at one decrease, spends many iterations
// (two passes over the observations each) on what m already estimates.
// Below model_tolerance x chi2 (1e-4: the precision the reference optima
// are held to; for chi2 near dof it is below chi2's statistical spread
// sqrt(2 / dof) while dof < 2e8) the solve stops, converged, termination
// "model_tolerance", without the line step. Only rejected steps are
// tested: an accepted step moves on (pose graphs accept steps whose model
// underestimates the decrease, rho up to 1.9, all the way to the optimum).
// Below function_tolerance x chi2 the stop holds whatever m estimates
// (termination "function_tolerance"): lambda only grows until the next
// accepted step, whose decrease is m there (rho = 1 where the model holds),
// so that step would stop the solve by the function tolerance. That
// matters where the cost jumps: a velocity motion's heading residual
// wraps at +-pi while its information couples heading and position
// (core/velocity_motion_model.h), so a pose turned half round by the start
// can sit on a minimum at the jump, where every step that crosses it is
// rejected whatever its length (rho -> -infinity as the step shrinks); the
// trust region would otherwise halve, quarter, ... down to
// min_trust_region_radius, one pass over the observations per try.
inline bool ModelDecreaseBelowTolerance(const SolverOptions& options, const TrialStep& trial,
                                        double chi2, SolverSummary* summary) {
  // A step the model does not expect to lower chi2 at all (m <= 0, an
  // inexact linear solve) says nothing about convergence.
  if (!trial.ok || !(trial.model_decrease > 0.0) ||
      !(trial.model_decrease < ModelStopTolerance(options) * chi2))
    return false;
  summary->termination = trial.model_decrease < options.function_tolerance * chi2
                             ? "function_tolerance"
                             : "model_tolerance";
  return true;
}

// The line search on a rejected step. Along the step d the cost is
// chi2(t) = chi2 + 2 t g^T d + t^2 d^T H d + (higher orders); the linear
// term is exact (the model's gradient is the cost's), so a step the model
// mispredicts is one whose higher orders dominate at t = 1: far from the
// optimum, where the linearized rotation of a pose chain moves its far end
// off the arc (a heading correction theta over a chain of length L moves it
// by L theta^2 / 2), or along a weakly determined mode whose step is long.
// There the Levenberg-Marquardt steps shrink only once lambda D reaches the
// mode's curvature, several rejected steps (two passes over the chunks
// each) later; one evaluation at a fraction of the step (one pass) usually
// decreases chi2 as the model predicts.
inline constexpr double kMinLineStep = 0.1;
inline constexpr double kMaxLineStep = 0.5;

// t minimizing the quadratic through chi2(0) = chi2, chi2'(0) = 2 g^T d and
// chi2(1) = candidate_chi2, in [kMinLineStep, kMaxLineStep].
inline double LineSearchFraction(double chi2, double gradient_dot_step, double candidate_chi2) {
  const double curvature = candidate_chi2 - chi2 - 2.0 * gradient_dot_step;
  if (!(curvature > 0.0)) return kMaxLineStep;
  return std::clamp(-gradient_dot_step / curvature, kMinLineStep, kMaxLineStep);
}

// The model decrease of the step t d: -2 t g^T d - t^2 d^T H d with
// d^T H d = -2 g^T d - m(1) (m(1) = trial.model_decrease).
inline double ModelDecreaseAt(double t, const TrialStep& trial) {
  return -2.0 * t * trial.gradient_dot_step +
         t * t * (2.0 * trial.gradient_dot_step + trial.model_decrease);
}

// Whether a rejected step gets a line search.
template <class Space>
bool SearchesLine(const SolverOptions& options, const TrialStep& trial, double chi2,
                  const Space& space) {
  return trial.ok && std::isfinite(trial.candidate_chi2) && trial.gradient_dot_step < 0.0 &&
         trial.model_decrease >= ModelStopTolerance(options) * chi2 &&
         options.abandon_below_rho <= 0.0 && space.SearchesLines();
}

// Hands the state after `iteration` to the checkpoint callback; the space
// lends its state for the write and gets it back even when the write fails.
template <class Space>
Status WriteLevenbergMarquardtCheckpoint(
    const std::function<Status(const typename Space::Checkpoint&)>& checkpoint_callback,
    int iteration, const LevenbergMarquardtState& state, bool converged,
    const SolverSummary& summary, Space* space) {
  typename Space::Checkpoint checkpoint;
  checkpoint.iterations = iteration;
  checkpoint.trust_region_radius = state.radius;
  checkpoint.decrease_factor = state.decrease_factor;
  checkpoint.initial_chi2 = summary.initial_chi2;
  checkpoint.chi2 = state.chi2;
  checkpoint.converged = converged;
  checkpoint.termination = converged ? summary.termination : "";
  space->LendState(&checkpoint);
  const Status written = checkpoint_callback(checkpoint);
  space->ReturnState(&checkpoint);  // before any return: the state must survive an error
  return written;
}

// Runs the iterations from the space's current state, whose chi2 is
// `initial_chi2` (or from `resume`, whose state the space has already taken
// over). Fills the control fields of *summary (chi2, iterations,
// per_iteration, termination, converged, seconds since `start`).
template <class Space>
Status RunLevenbergMarquardt(
    const SolverOptions& options, double initial_chi2, const typename Space::Checkpoint* resume,
    const std::function<Status(const typename Space::Checkpoint&)>& checkpoint_callback,
    SolverClock::time_point start, Space* space, SolverSummary* summary) {
  LevenbergMarquardtState state;
  state.chi2 = initial_chi2;
  summary->initial_chi2 = initial_chi2;
  summary->final_chi2 = initial_chi2;
  if (!std::isfinite(initial_chi2)) {
    return Status::Numerical("initial chi2 is not finite (" + std::to_string(initial_chi2) +
                             "); check the initial guess and information matrices");
  }
  state.radius = options.initial_trust_region_radius;
  // Pose graphs without checkpoints: the spaces that accelerate steps.
  const bool extrapolate = resume == nullptr && !checkpoint_callback && space->AcceleratesSteps();
  int first_iteration = 1;
  // Whether this iteration's pass reduces ahead at its candidate: at the
  // start (and after a resume), then after every accepted step. A hit (this
  // step accepted with rho >= kSpeculationRho) saves the next iteration's
  // read and linearization of every chunk; a miss costs the Jacobians and
  // eliminations of one reduction, and no read. The last step's rho is a
  // poor guess of this one's: an accepted step of mid-range rho is mostly
  // followed by one that fits.
  bool speculate = true;
  if (resume != nullptr) {
    RestoreFromCheckpoint(*resume, options, &state, summary);
    first_iteration = resume->iterations + 1;
    if (resume->converged) {
      summary->seconds = SecondsSince(start);
      return Status::Ok();
    }
  }
  summary->termination = "max_iterations";
  // The start is a checkpoint too (iteration 0): a solve killed during its
  // first iteration resumes from its initialized start instead of
  // initializing again, which at 10^8 features is most of an hour.
  if (checkpoint_callback && resume == nullptr) {
    GS_RETURN_IF_ERROR(WriteLevenbergMarquardtCheckpoint(checkpoint_callback, 0, state,
                                                         /*converged=*/false, *summary, space));
  }

  for (int iteration = first_iteration; iteration <= options.max_iterations; ++iteration) {
    const SolverClock::time_point iteration_start = SolverClock::now();
    IterationSummary it;
    it.iteration = iteration;
    it.lambda = 1.0 / state.radius;
    it.start_chi2 = state.chi2;

    // 1. Linearize and reduce.
    bool usable = true;
    GS_RETURN_IF_ERROR(space->Linearize(it.lambda, &it, &usable));
    it.reduce_seconds = SecondsSince(iteration_start);
    if (usable && it.gradient_max_norm <= options.gradient_tolerance) {
      summary->termination = "gradient_tolerance";
      summary->converged = true;
      break;
    }

    // 2-3. Solve the reduced system, recover, evaluate the candidate.
    TrialStep trial;
    const double speculative_lambda =
        speculate && iteration < options.max_iterations
            ? 1.0 / RadiusAfterAcceptedStep(state.radius, 1.0, state.fit_so_far, options)
            : 0.0;
    GS_RETURN_IF_ERROR(space->TryStep(it.lambda, speculative_lambda, usable, &it, &trial));
    double candidate_chi2 = trial.ok ? trial.candidate_chi2
                                           : std::numeric_limits<double>::infinity();
    it.candidate_chi2 = candidate_chi2;
    it.relative_decrease =
        trial.model_decrease > 0.0 ? (state.chi2 - candidate_chi2) / trial.model_decrease : -1.0;
    it.accepted = trial.ok && std::isfinite(candidate_chi2) &&
                  it.relative_decrease > options.min_relative_decrease;
    if (trial.ok) space->StepResult(it.accepted);
    speculate = it.accepted;

    // 4. Accept (the accelerated step if it is better) or reject; update
    //    the trust region.
    GS_RETURN_IF_ERROR(MaybeAccelerate(space, &candidate_chi2, &it));
    bool converged = false;
    if (it.accepted) {
      GS_RETURN_IF_ERROR(space->Accept());
      converged = UpdateAfterAcceptedStep(options, extrapolate, trial, candidate_chi2, it, &state,
                                          summary);
    } else if (SearchesLine(options, trial, state.chi2, *space)) {
      const double t = LineSearchFraction(state.chi2, trial.gradient_dot_step, candidate_chi2);
      bool computed = false;
      double line_chi2 = 0.0;
      // The radius UpdateAfterRejectedStep leaves, which an accepted line
      // step keeps (UpdateAfterLineStep): the next lambda, bit for bit.
      const double line_next_lambda =
          iteration < options.max_iterations ? 1.0 / (state.radius / state.decrease_factor)
                                             : 0.0;
      GS_RETURN_IF_ERROR(space->ScaledStepChi2(t, line_next_lambda, &computed, &line_chi2));
      const double line_model = ModelDecreaseAt(t, trial);
      const double line_rho = (state.chi2 - line_chi2) / line_model;
      UpdateAfterRejectedStep(&state);
      ++it.chunk_passes;
      if (computed && line_model > 0.0 && line_rho > options.min_relative_decrease) {
        GS_VLOG(1, "%siteration %d: line search t %.3g: chi2 %.9g rho %.3g accepted",
                Space::kName, iteration, t, line_chi2, line_rho);
        it.line_search_fraction = t;
        it.accepted = true;
        it.candidate_chi2 = line_chi2;
        it.step_norm *= t;
        space->StepResult(true);
        GS_RETURN_IF_ERROR(space->Accept());
        converged = UpdateAfterLineStep(options, line_chi2, &state, summary);
      } else {
        converged = ModelDecreaseBelowTolerance(options, trial, state.chi2, summary);
      }
    } else {
      UpdateAfterRejectedStep(&state);
      converged = ModelDecreaseBelowTolerance(options, trial, state.chi2, summary);
    }
    it.chi2 = state.chi2;
    it.seconds = SecondsSince(iteration_start);
    summary->per_iteration.push_back(it);
    summary->iterations = iteration;
    summary->final_chi2 = state.chi2;
    GS_VLOG(1, "%siteration %d: chi2 %.9g candidate %.9g rho %.3g lambda %.3g |step| %.3g cg %d %s%s",
            Space::kName, iteration, state.chi2, candidate_chi2, it.relative_decrease, it.lambda,
            it.step_norm, it.linear_iterations, it.accepted ? "accepted" : "rejected",
            it.accelerated ? " (accelerated)" : "");
    if (options.iteration_callback) options.iteration_callback(it);
    // Total 0 (unknown): the loop stops on convergence, not at max_iterations.
    // An iteration callback already shows every iteration.
    if (options.progress && !options.iteration_callback)
      options.progress("optimize", iteration, 0);
    if (!converged && state.radius < options.min_trust_region_radius) {
      summary->termination = "min_trust_region_radius";
      converged = true;  // no further decrease possible: a (local) minimum
    }
    // Only a step that meant to matter (a model decrease above 0.1 % of
    // chi2) tells about the start: near a minimum rho is roundoff.
    const bool abandoned = !converged && options.abandon_below_rho > 0.0 &&
                           !(it.relative_decrease >= options.abandon_below_rho) &&
                           trial.model_decrease > 1e-3 * it.start_chi2;
    if (abandoned) summary->termination = "abandoned";
    if (checkpoint_callback) {
      GS_RETURN_IF_ERROR(WriteLevenbergMarquardtCheckpoint(checkpoint_callback, iteration, state,
                                                           converged, *summary, space));
    }
    if (converged) {
      summary->converged = true;
      break;
    }
    if (abandoned) break;
  }
  summary->seconds = SecondsSince(start);
  return Status::Ok();
}

}  // namespace graphslam::core
