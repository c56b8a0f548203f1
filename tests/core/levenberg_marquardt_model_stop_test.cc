// The stop on a rejected step's model decrease (core/levenberg_marquardt.h,
// ModelDecreaseBelowTolerance with SolverOptions::model_tolerance): a slow
// tail of line steps ends once the model's estimate of the chi2 still to
// gain falls below model_tolerance x chi2, not earlier, and without the
// rule the same tail runs on to the function tolerance.
#include <gtest/gtest.h>

#include <string>

#include "core/graphslam_solver.h"
#include "core/levenberg_marquardt.h"

namespace graphslam::core {
namespace {

// A scripted tail: chi2 = optimum + remaining. Every full step is rejected
// (its chi2 rises by kRise x m), its model decrease m is kModelShare of the
// remaining chi2 (the damped model underestimates it), and the line step
// gains kLineShare of m: the remaining decrease falls geometrically,
// remaining' = (1 - kLineShare kModelShare) remaining, one known sequence.
class ScriptedTailSpace {
 public:
  using Checkpoint = SolverCheckpoint;
  static constexpr const char* kName = "scripted: ";
  static constexpr double kModelShare = 0.85;
  static constexpr double kLineShare = 0.13;
  static constexpr double kRise = 30.0;

  ScriptedTailSpace(double optimum, double remaining)
      : optimum_(optimum), remaining_(remaining) {}

  double chi2() const { return optimum_ + remaining_; }
  int line_evaluations() const { return line_evaluations_; }

  Status Linearize(double, IterationSummary* it, bool* usable) {
    it->gradient_max_norm = 1.0;
    *usable = true;
    return Status::Ok();
  }
  Status TryStep(double, double, bool, IterationSummary* it, TrialStep* trial) {
    const double m = kModelShare * remaining_;
    trial->ok = true;
    trial->model_decrease = m;
    trial->candidate_chi2 = chi2() + kRise * m;
    // chi2(t) = chi2 + 2 t g^T d + t^2 (-2 g^T d - m): the slope of a
    // model whose minimizer along d is the full step.
    trial->gradient_dot_step = -m;
    trial->state_norm_squared = 1.0;
    it->step_norm = 1.0;
    return Status::Ok();
  }
  void StepResult(bool) {}
  bool SearchesLines() const { return true; }
  Status ScaledStepChi2(double, double, bool* computed, double* chi2_at_t) {
    ++line_evaluations_;
    candidate_remaining_ = remaining_ - kLineShare * kModelShare * remaining_;
    *computed = true;
    *chi2_at_t = optimum_ + candidate_remaining_;
    return Status::Ok();
  }
  bool AcceleratesSteps() const { return false; }
  Status AcceleratedStepChi2(bool* computed, double*) {
    *computed = false;
    return Status::Ok();
  }
  void TakeAcceleratedStep() {}
  void ForgetAcceleration() {}
  Status Accept() {
    remaining_ = candidate_remaining_;
    return Status::Ok();
  }
  void LendState(Checkpoint*) {}
  void ReturnState(Checkpoint*) {}

 private:
  double optimum_;
  double remaining_;
  double candidate_remaining_ = 0.0;
  int line_evaluations_ = 0;
};

// The iteration whose rejected step first has m < tolerance x chi2 (the
// solve stops there without its line step), from the known sequence.
int ExpectedStopIteration(double optimum, double remaining, double tolerance) {
  for (int iteration = 1;; ++iteration) {
    const double m = ScriptedTailSpace::kModelShare * remaining;
    if (m < tolerance * (optimum + remaining)) return iteration;
    remaining -= ScriptedTailSpace::kLineShare * m;
  }
}

SolverSummary RunTail(const SolverOptions& options, ScriptedTailSpace* space) {
  SolverSummary summary;
  const Status status =
      RunLevenbergMarquardt(options, space->chi2(), nullptr, {}, SolverClock::now(), space,
                            &summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return summary;
}

TEST(LevenbergMarquardtModelStop, StopsAGeometricTailWhereTheModelFallsBelowTolerance) {
  const double optimum = 5.7e7;
  const double remaining = 1e-3 * optimum;  // 10x the tolerance
  SolverOptions options;
  ASSERT_EQ(options.model_tolerance, 1e-4) << "the default this test describes";
  ScriptedTailSpace space(optimum, remaining);
  const SolverSummary summary = RunTail(options, &space);
  const int expected = ExpectedStopIteration(optimum, remaining, options.model_tolerance);
  ASSERT_GT(expected, 2) << "the tail must start above the tolerance";
  EXPECT_TRUE(summary.converged);
  EXPECT_EQ(summary.termination, "model_tolerance");
  EXPECT_EQ(summary.iterations, expected);
  // Every iteration before the last took its line step; the last none.
  EXPECT_EQ(space.line_evaluations(), expected - 1);
  for (const IterationSummary& it : summary.per_iteration)
    EXPECT_EQ(it.accepted, it.iteration < expected) << "iteration " << it.iteration;
  // What is left is what the model estimated, within its share.
  const double left = summary.final_chi2 - optimum;
  EXPECT_LT(ScriptedTailSpace::kModelShare * left, options.model_tolerance * summary.final_chi2);
  EXPECT_LT(left, options.model_tolerance * summary.final_chi2 / ScriptedTailSpace::kModelShare);
}

TEST(LevenbergMarquardtModelStop, DoesNotStopWhileTheModelDecreaseIsSignificant) {
  const double optimum = 5.7e7;
  SolverOptions options;
  // Above the tolerance at every iteration the cap allows: no model stop.
  const double remaining = 1e-1 * optimum;
  options.max_iterations = ExpectedStopIteration(optimum, remaining, options.model_tolerance) - 1;
  ASSERT_GT(options.max_iterations, 5);
  ScriptedTailSpace space(optimum, remaining);
  const SolverSummary summary = RunTail(options, &space);
  EXPECT_FALSE(summary.converged);
  EXPECT_EQ(summary.termination, "max_iterations");
  EXPECT_EQ(summary.iterations, options.max_iterations);
  EXPECT_EQ(space.line_evaluations(), options.max_iterations);
}

// Without the rule (model_tolerance 0) the same tail runs on until a line
// step lowers chi2 by less than the function tolerance: many more
// iterations for a chi2 lower by less than model_tolerance x chi2 over the
// model's share of the remaining decrease.
TEST(LevenbergMarquardtModelStop, WithoutTheRuleTheTailRunsToTheFunctionTolerance) {
  const double optimum = 5.7e7;
  const double remaining = 1e-3 * optimum;
  SolverOptions with_rule;
  SolverOptions without = with_rule;
  without.model_tolerance = 0.0;
  ScriptedTailSpace a(optimum, remaining);
  ScriptedTailSpace b(optimum, remaining);
  const SolverSummary stopped = RunTail(with_rule, &a);
  const SolverSummary full = RunTail(without, &b);
  EXPECT_EQ(full.termination, "function_tolerance");
  EXPECT_GT(full.iterations, 2 * stopped.iterations);
  EXPECT_LT(full.final_chi2, stopped.final_chi2);
  EXPECT_LT(stopped.final_chi2 - full.final_chi2,
            with_rule.model_tolerance * stopped.final_chi2 / ScriptedTailSpace::kModelShare);
}

TEST(LevenbergMarquardtModelStop, ToleranceIsTheLargerOfModelAndFunctionTolerance) {
  SolverOptions options;
  options.function_tolerance = 1e-6;
  options.model_tolerance = 1e-4;
  TrialStep trial;
  trial.ok = true;
  const double chi2 = 1000.0;
  SolverSummary summary;
  trial.model_decrease = 0.2;  // 2e-4 of chi2
  EXPECT_FALSE(ModelDecreaseBelowTolerance(options, trial, chi2, &summary));
  trial.model_decrease = 0.05;  // 5e-5
  EXPECT_TRUE(ModelDecreaseBelowTolerance(options, trial, chi2, &summary));
  EXPECT_EQ(summary.termination, "model_tolerance");
  trial.model_decrease = 5e-4;  // 5e-7: below the function tolerance too
  EXPECT_TRUE(ModelDecreaseBelowTolerance(options, trial, chi2, &summary));
  EXPECT_EQ(summary.termination, "function_tolerance");
  options.model_tolerance = 0.0;  // off: the function tolerance alone
  trial.model_decrease = 0.05;
  EXPECT_FALSE(ModelDecreaseBelowTolerance(options, trial, chi2, &summary));
  trial.model_decrease = -1.0;  // a model that expects no decrease
  EXPECT_FALSE(ModelDecreaseBelowTolerance(options, trial, chi2, &summary));
  // A step below the tolerance gets no line search (it ends the solve).
  ScriptedTailSpace space(chi2, 1.0);
  options.model_tolerance = 1e-4;
  trial.candidate_chi2 = chi2 + 1.0;
  trial.gradient_dot_step = -0.05;
  trial.model_decrease = 0.05;
  EXPECT_FALSE(SearchesLine(options, trial, chi2, space));
  trial.model_decrease = 0.2;
  EXPECT_TRUE(SearchesLine(options, trial, chi2, space));
}

TEST(LevenbergMarquardtModelStop, ValidateChecksTheRange) {
  SolverOptions options;
  EXPECT_TRUE(options.Validate().ok());
  options.model_tolerance = -1e-3;
  EXPECT_FALSE(options.Validate().ok());
  options.model_tolerance = 1.0;
  EXPECT_FALSE(options.Validate().ok());
  options.model_tolerance = 0.0;
  EXPECT_TRUE(options.Validate().ok());
}

}  // namespace
}  // namespace graphslam::core
