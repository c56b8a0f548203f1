// The trust region update of core/levenberg_marquardt.h: the radius grows
// kFitRadiusGrowth times per step while the model has fit every step, and
// follows Nielsen's rule once a step fits less or is rejected; and the
// stopping tests.
#include "core/levenberg_marquardt.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "core/graphslam_solver.h"
#include "core/pose_factors.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/g2o_reader.h"
#include "tests/testing/datasets.h"
#include "tests/testing/heading_perturbed_problem.h"
#include "tests/testing/random_problem.h"

namespace graphslam::core {
namespace {

TEST(LevenbergMarquardt, RadiusGrowsTenfoldOnlyWhileTheModelFits) {
  SolverOptions options;
  options.max_trust_region_radius = 1e16;
  EXPECT_EQ(RadiusAfterAcceptedStep(1e8, 1.0, true, options), 1e9);
  EXPECT_EQ(RadiusAfterAcceptedStep(1e8, kSpeculationRho, true, options), 1e9);
  // Nielsen: radius / max(1/3, 1 - (2 rho - 1)^3).
  EXPECT_EQ(RadiusAfterAcceptedStep(1e8, 1.0, false, options), 1e8 / (1.0 / 3.0));
  EXPECT_DOUBLE_EQ(RadiusAfterAcceptedStep(1e8, 0.5, true, options), 1e8);
  EXPECT_DOUBLE_EQ(RadiusAfterAcceptedStep(1e8, 0.75, true, options), 1e8 / 0.875);
  EXPECT_EQ(RadiusAfterAcceptedStep(1e16, 1.0, true, options), 1e16);  // capped
  // The speculated radius (rho = 1) is the one every rho >= kSpeculationRho gives.
  for (bool fit : {true, false}) {
    EXPECT_EQ(RadiusAfterAcceptedStep(3e5, 0.95, fit, options),
              RadiusAfterAcceptedStep(3e5, 1.0, fit, options));
    EXPECT_EQ(RadiusAfterAcceptedStep(3e5, 1.7, fit, options),
              RadiusAfterAcceptedStep(3e5, 1.0, fit, options));
  }
}

TEST(LevenbergMarquardt, ResumeRecognizesARadiusGrownAtEveryStep) {
  SolverOptions options;
  options.initial_trust_region_radius = 1e8;
  options.max_trust_region_radius = 1e16;
  EXPECT_TRUE(ModelFitEveryStep(0, 1e8, options));
  double radius = 1e8;
  for (int k = 1; k <= 12; ++k) {
    radius = RadiusAfterAcceptedStep(radius, 1.0, true, options);
    EXPECT_TRUE(ModelFitEveryStep(k, radius, options)) << k;
  }
  EXPECT_EQ(radius, 1e16);
  EXPECT_FALSE(ModelFitEveryStep(2, 1e8 * 3.0 * 3.0, options));
  EXPECT_FALSE(ModelFitEveryStep(1, 1e8 / 2.0, options));  // a rejected first step
}

// intel from the file's own guess with CHOLMOD at the default start; a
// checkpoint callback (that writes nothing) when asked.
SolverSummary SolveIntel(bool checkpoints) {
  SolverSummary summary;
  StatusOr<Problem2d> problem =
      storage::ReadG2o(graphslam::testing::DatasetPath("freiburg_course_g2o/intel.g2o"));
  EXPECT_TRUE(problem.ok()) << problem.status().ToString();
  if (!problem.ok()) return summary;
  partition::InMemoryChunkSource chunks(*problem, partition::ChunkingOptions());
  SolverOptions options;
  options.linear_solver = LinearSolverType::kCholmod;
  options.initial_trust_region_radius = kDirectInitialTrustRegion;
  if (checkpoints)
    options.checkpoint_callback = [](const SolverCheckpoint&) { return Status::Ok(); };
  const Status status = SolveGraphSlam(options, chunks, &*problem, &summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return summary;
}

// intel: every step fits (rho >= kSpeculationRho), so lambda falls 10x per
// iteration; the optimum is the reference one.
TEST(LevenbergMarquardt, IntelDampingFallsTenfoldPerFittingStep) {
  GS_REQUIRE_DATASET("freiburg_course_g2o/intel.g2o");
  const SolverSummary summary = SolveIntel(false);
  EXPECT_TRUE(summary.converged) << summary.termination;
  EXPECT_NEAR(summary.final_chi2, 359.996112, 1e-6 * 359.996112);
  const std::vector<IterationSummary>& its = summary.per_iteration;
  ASSERT_GE(its.size(), 3u);
  double radius = kDirectInitialTrustRegion;
  for (const IterationSummary& it : its) {
    EXPECT_EQ(it.lambda, 1.0 / radius) << "iteration " << it.iteration;
    ASSERT_TRUE(it.accepted);
    ASSERT_GE(it.relative_decrease, kSpeculationRho) << "iteration " << it.iteration;
    radius *= kFitRadiusGrowth;
  }
}

TEST(LevenbergMarquardt, ExtrapolatesOnlyASuperlinearContraction) {
  // Decreases 100, 5, 0.01 at chi2 1000: next ~2e-5 < 1e-6 x 1000.
  EXPECT_TRUE(ExtrapolatedDecreaseBelow(100.0, 5.0, 0.01, 1000.0, 1e-6));
  EXPECT_FALSE(ExtrapolatedDecreaseBelow(100.0, 5.0, 0.01, 1000.0, 1e-8));
  EXPECT_FALSE(ExtrapolatedDecreaseBelow(100.0, 20.0, 0.01, 1000.0, 1e-6));  // 0.2 contraction
  EXPECT_FALSE(ExtrapolatedDecreaseBelow(100.0, 5.0, 0.6, 1000.0, 1e-2));    // 0.12 contraction
  EXPECT_FALSE(ExtrapolatedDecreaseBelow(0.0, 5.0, 0.01, 1000.0, 1e-6));     // unqualified step
  EXPECT_FALSE(ExtrapolatedDecreaseBelow(100.0, 0.0, 0.0, 1000.0, 1e-6));
  EXPECT_FALSE(ExtrapolatedDecreaseBelow(100.0, 5.0, 0.01, 1000.0, 0.0));  // tolerance off
}

// intel converges quadratically: the extrapolated test stops it one
// iteration before the plain test would (a checkpoint callback turns the
// extrapolation off), at a chi2 above that one's by less than the tolerance.
TEST(LevenbergMarquardt, IntelStopsOneConfirmingIterationEarly) {
  GS_REQUIRE_DATASET("freiburg_course_g2o/intel.g2o");
  const SolverSummary extrapolated = SolveIntel(false);
  const SolverSummary plain = SolveIntel(true);
  ASSERT_FALSE(plain.per_iteration.empty());
  EXPECT_TRUE(extrapolated.converged);
  EXPECT_EQ(extrapolated.termination, "function_tolerance");
  EXPECT_EQ(extrapolated.iterations + 1, plain.iterations);
  const double last_decrease = plain.per_iteration.back().start_chi2 - plain.final_chi2;
  EXPECT_GE(last_decrease, 0.0);
  EXPECT_LT(last_decrease, 1e-6 * plain.final_chi2);
  EXPECT_NEAR(extrapolated.final_chi2, plain.final_chi2, 1e-6 * plain.final_chi2);
  EXPECT_NEAR(extrapolated.final_chi2, 359.996112, 1e-8 * 359.996112);
}

// tests/testing/heading_perturbed_problem.h: the first full steps overshoot.
Problem2d HeadingPerturbedProblem(uint32_t seed) {
  testing::HeadingPerturbation perturbation;
  perturbation.seed = seed;
  return testing::HeadingPerturbedProblem(perturbation);
}

// Headings off by up to 2.5 rad: some step is rejected or fits poorly;
// from then on the radius grows at most 3x per step (Nielsen).
TEST(LevenbergMarquardt, NielsenAfterAStepThatDidNotFit) {
  int checked = 0;
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    Problem2d problem = HeadingPerturbedProblem(seed);
    partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
    SolverOptions options;
    options.linear_solver = LinearSolverType::kCholmod;
    options.function_tolerance = 1e-12;
    options.max_iterations = 30;
    SolverSummary summary;
    ASSERT_TRUE(SolveGraphSlam(options, chunks, &problem, &summary).ok());
    const std::vector<IterationSummary>& its = summary.per_iteration;
    bool fit_so_far = true;
    for (size_t k = 0; k + 1 < its.size(); ++k) {
      fit_so_far = fit_so_far && its[k].accepted && its[k].relative_decrease >= kSpeculationRho;
      const double growth = its[k].lambda / its[k + 1].lambda;
      if (1.0 / its[k + 1].lambda >= 0.5 * options.max_trust_region_radius) continue;  // capped
      if (fit_so_far) {
        EXPECT_DOUBLE_EQ(growth, kFitRadiusGrowth) << "seed " << seed << " iteration " << k + 1;
      } else {
        EXPECT_LE(growth, 3.0 * (1.0 + 1e-12)) << "seed " << seed << " iteration " << k + 1;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 10);
}

// The stall of a velocity motion whose heading residual sits at +pi while its
// information couples heading and position (a pose turned half round by the
// start, as the pose-graph start leaves one on graphslam benchmark's
// campuses). Pose 0 is fixed at the origin and predicts pose 1 at (1, 0, 0);
// a GPS fix holds pose 1 at x = -2.5. With
//   W = [4 0 2; 0 4 0; 2 0 2]
// the cost in the heading residual t is 2 t^2 + 4 t e_x + ..., whose vertex
// -e_x ~ 3.43 lies beyond pi: the wrapped cost is least at t = pi itself,
// and pose 1 starts there, its position at the best one for t = pi. Every
// step turns it past pi, where t wraps to -pi and the cost jumps by
// -8 pi e_x ~ 86, however short the step: all are rejected. The solve must
// stop there by the function tolerance (the model's decrease below it), not
// halve the trust region down to min_trust_region_radius.
TEST(LevenbergMarquardt, MinimumOnAHeadingJumpStopsByTheFunctionTolerance) {
  const double pi = std::numbers::pi;
  Problem2d problem;
  problem.AddPose(0, Pose2(0.0, 0.0, 0.0), true, 0);
  problem.pose_fixed[0] = 1;
  Eigen::Matrix3d w;
  w << 4, 0, 2, 0, 4, 0, 2, 0, 2;
  const Eigen::Matrix2d gps_information = 100.0 * Eigen::Matrix2d::Identity();
  const Eigen::Vector2d predicted(1.0, 0.0);
  const Eigen::Vector2d fix(-2.5, 0.0);
  // The position that minimizes the cost with t = pi:
  // (W_rr + G) e_r = G (fix - predicted) - pi W_rt.
  const Eigen::Vector2d e_r =
      (w.topLeftCorner<2, 2>() + gps_information)
          .ldlt()
          .solve(gps_information * (fix - predicted) - pi * w.topRightCorner<2, 1>());
  ASSERT_GT(-w(2, 0) * e_r.x() / w(2, 2), pi) << "the vertex must lie beyond pi";
  const Eigen::Vector2d start = predicted + e_r;
  problem.AddPose(1, Pose2(start.x(), start.y(), pi), true, 0);
  VelocityMotionConstraint motion;
  motion.from = 0;
  motion.to = 1;
  motion.control = {1.0, 0.0, 1.0};
  motion.information = w;
  problem.motions.push_back(motion);
  GpsConstraint gps;
  gps.pose = 1;
  gps.z = fix;
  gps.information = gps_information;
  problem.gps.push_back(gps);
  const Eigen::Vector3d e(e_r.x(), e_r.y(), pi);
  const double edge_chi2 = e.dot(w * e) + (start - fix).dot(gps_information * (start - fix));
  ASSERT_NEAR(PoseFactorsChi2(problem, problem.poses), edge_chi2, 1e-12 * edge_chi2);
  // q(-pi) - q(pi) with W_tr e_r = W_tx e_x.
  const double jump = -4.0 * pi * w(2, 0) * e_r.x();

  partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
  SolverOptions options;
  options.linear_solver = LinearSolverType::kCholmod;
  // The function tolerance's own stop (the model tolerance, looser, would
  // end it sooner by the same test).
  options.model_tolerance = 0.0;
  SolverSummary summary;
  ASSERT_TRUE(SolveGraphSlam(options, chunks, &problem, &summary).ok());
  EXPECT_TRUE(summary.converged);
  EXPECT_EQ(summary.termination, "function_tolerance");
  for (const IterationSummary& it : summary.per_iteration) {
    EXPECT_FALSE(it.accepted) << "iteration " << it.iteration;
    EXPECT_GT(it.candidate_chi2 - it.start_chi2, 0.8 * jump) << "iteration " << it.iteration;
  }
  EXPECT_EQ(summary.final_chi2, summary.initial_chi2);
  EXPECT_NEAR(summary.final_chi2, edge_chi2, 1e-12 * edge_chi2);
  EXPECT_EQ(problem.poses[1], Pose2(start.x(), start.y(), pi));
}


// The line search's fraction and model along a step, against a quadratic
// chi2(t) = a + b t + c t^2 whose model is exact: g^T d = b / 2 and
// m(1) = -(b + c) (the Levenberg-Marquardt model decrease with d^T H d = c).
TEST(LevenbergMarquardt, LineSearchModelIsTheQuadraticAlongTheStep) {
  const double a = 100.0;
  for (double b : {-3.0, -40.0}) {
    for (double c : {0.5, 4.0, 200.0}) {
      TrialStep trial;
      trial.gradient_dot_step = b / 2.0;
      trial.model_decrease = -(b + c);
      const double chi2_1 = a + b + c;
      const double t = LineSearchFraction(a, trial.gradient_dot_step, chi2_1);
      EXPECT_DOUBLE_EQ(t, std::clamp(-b / (2.0 * c), kMinLineStep, kMaxLineStep))
          << "b " << b << " c " << c;
      for (double s : {0.1, 0.3, 1.0}) {
        EXPECT_NEAR(ModelDecreaseAt(s, trial), -(b * s + c * s * s), 1e-12 * std::abs(b))
            << "b " << b << " c " << c << " t " << s;
      }
    }
  }
  // No curvature seen (chi2(1) below the tangent): the longest fraction.
  EXPECT_EQ(LineSearchFraction(10.0, -1.0, 7.0), kMaxLineStep);
}

// Headings perturbed by up to 2.5 rad: the first full steps overshoot (the
// linearized rotation of the chain), and the line search takes a fraction
// of a rejected step instead of the next, more damped one. Every step so
// taken lowers chi2 and is reported as the accepted candidate.
TEST(LevenbergMarquardt, LineSearchTakesAFractionOfARejectedStep) {
  int line_steps = 0;
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    Problem2d problem = HeadingPerturbedProblem(seed);
    partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
    SolverOptions options;
    options.linear_solver = LinearSolverType::kCholmod;
    options.function_tolerance = 1e-12;
    options.max_iterations = 60;
    SolverSummary summary;
    ASSERT_TRUE(SolveGraphSlam(options, chunks, &problem, &summary).ok());
    EXPECT_TRUE(summary.converged) << "seed " << seed;
    for (const IterationSummary& it : summary.per_iteration) {
      if (it.line_search_fraction == 0.0) continue;
      ++line_steps;
      EXPECT_TRUE(it.accepted);
      EXPECT_GE(it.line_search_fraction, kMinLineStep);
      EXPECT_LE(it.line_search_fraction, kMaxLineStep);
      EXPECT_LT(it.chi2, it.start_chi2) << "seed " << seed << " iteration " << it.iteration;
      EXPECT_EQ(it.chi2, it.candidate_chi2);
    }
  }
  EXPECT_GT(line_steps, 0);
}

}  // namespace
}  // namespace graphslam::core
