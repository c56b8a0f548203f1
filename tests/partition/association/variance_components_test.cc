// Tests of the variance components per constraint type
// (partition/association/variance_components.h) on simulated problems with a
// known answer: the odometry's noise is k times its stated sigma, the
// observations' exactly the stated one, so the factors are ~k^2 and ~1, where
// one pooled factor lies between them.
#include "partition/association/variance_components.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

#include "core/graphslam_solver.h"
#include "core/se2.h"
#include "partition/association/internal/variance_factor.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/tight_solver_options.h"

namespace graphslam::partition {
namespace {

struct Simulation {
  double odometry_scale = 1.0;     // true odometry sigma / stated
  double observation_scale = 1.0;  // true observation sigma / stated
  int gps_every = 0;               // 0: no GPS (pose 0 anchors)
  double gps_scale = 1.0;
  uint32_t seed = 1;
};

// Two laps of a 12 m circle, 400 poses, 40 landmarks seen as range-bearing
// within 6 m; the stated sigmas are those of the inputs, the drawn noise is
// the stated times the scales.
core::Problem2d Simulate(const Simulation& sim) {
  std::mt19937 rng(sim.seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  core::Problem2d problem;
  const int poses = 400;
  const double radius = 12.0;
  std::vector<core::Pose2> truth;
  for (int i = 0; i < poses; ++i) {
    const double a = 4.0 * std::numbers::pi * i / poses;
    truth.emplace_back(radius * std::cos(a), radius * std::sin(a),
                       core::WrapAngle(a + std::numbers::pi / 2));
    problem.AddPose(i, truth.back(), true, 0, static_cast<double>(i));
  }
  std::vector<core::Point2> landmarks;
  for (int j = 0; j < 40; ++j) {
    const double a = 2.0 * std::numbers::pi * uniform(rng);
    const double r = radius + (uniform(rng) < 0.5 ? -1.0 : 1.0) * (1.0 + 3.0 * uniform(rng));
    landmarks.emplace_back(r * std::cos(a), r * std::sin(a));
    problem.AddFeature(j, landmarks.back(), true);
  }
  const double sxy = 0.05, st = 0.01, sr = 0.1, sb = 0.02;
  for (int i = 0; i + 1 < poses; ++i) {
    core::RelativePoseConstraint c;
    c.from = i;
    c.to = i + 1;
    c.z = core::Between(truth[i], truth[i + 1]) +
          sim.odometry_scale * Eigen::Vector3d(sxy * normal(rng), sxy * normal(rng), st * normal(rng));
    c.information = Eigen::Vector3d(1 / (sxy * sxy), 1 / (sxy * sxy), 1 / (st * st)).asDiagonal();
    problem.relative_poses.push_back(c);
  }
  for (int i = 0; i < poses; ++i) {
    for (int j = 0; j < static_cast<int>(landmarks.size()); ++j) {
      const Eigen::Vector2d d = landmarks[j] - truth[i].head<2>();
      if (d.norm() > 6.0) continue;
      core::Observation o;
      o.pose = i;
      o.feature = j;
      o.kind = core::ObservationKind::kRangeBearing;
      o.z = Eigen::Vector2d(d.norm() + sim.observation_scale * sr * normal(rng),
                            core::WrapAngle(std::atan2(d.y(), d.x()) - truth[i].z() +
                                            sim.observation_scale * sb * normal(rng)));
      o.information = Eigen::Vector2d(1 / (sr * sr), 1 / (sb * sb)).asDiagonal();
      problem.observations.push_back(o);
    }
  }
  for (int i = 0; sim.gps_every > 0 && i < poses; i += sim.gps_every) {
    core::GpsConstraint g;
    g.pose = i;
    g.z = truth[i].head<2>() + sim.gps_scale * 0.3 * Eigen::Vector2d(normal(rng), normal(rng));
    g.information = Eigen::Matrix2d::Identity() / 0.09;
    problem.gps.push_back(g);
  }
  if (sim.gps_every == 0) problem.pose_fixed[0] = 1;
  return problem;
}

// Solves the problem and estimates the components at the optimum; *pooled is
// chi2 / (m - n) of that solve (not clamped).
void SolveAndEstimate(core::Problem2d* problem, VarianceComponents* components,
                      double* pooled) {
  const core::SolverOptions options = testing::TightCholmodSolverOptions();
  ChunkingOptions chunking;
  core::SolverSummary summary;
  {
    InMemoryChunkSource chunks(*problem, chunking);
    ASSERT_TRUE(core::SolveGraphSlam(options, chunks, problem, &summary).ok());
  }
  InMemoryChunkSource chunks(*problem, chunking);
  core::PoseMarginals marginals;
  std::vector<FeatureState> states;
  ASSERT_TRUE(LinearizeAtSolution(options, chunks, *problem, &marginals, &states).ok());
  ASSERT_TRUE(EstimateVarianceComponents(*problem, marginals, states, options.observation_kernel,
                                         1.0, components)
                  .ok());
  const double redundancy = components->observations.redundancy + components->gps.redundancy +
                            components->pose_constraints.redundancy;
  *pooled = summary.final_chi2 / redundancy;
}

// Foerstner's iteration: re-weights each group by its factor, solves again
// and re-estimates; returns the accumulated factors (observations, pose
// constraints, GPS) relative to the stated models.
Eigen::Vector3d IterateComponents(core::Problem2d problem, int iterations) {
  Eigen::Vector3d total = Eigen::Vector3d::Ones();
  for (int it = 0; it < iterations; ++it) {
    VarianceComponents c;
    double pooled = 0.0;
    SolveAndEstimate(&problem, &c, &pooled);
    const Eigen::Vector3d step(c.observations.factor, c.pose_constraints.factor, c.gps.factor);
    total = total.cwiseProduct(step);
    for (core::Observation& o : problem.observations) o.information /= step(0);
    for (core::RelativePoseConstraint& r : problem.relative_poses) r.information /= step(1);
    for (core::GpsConstraint& g : problem.gps) g.information /= step(2);
  }
  return total;
}

TEST(VarianceComponents, StatedModelsGiveFactorsNearOne) {
  Simulation sim;
  core::Problem2d problem = Simulate(sim);
  VarianceComponents c;
  double pooled = 0.0;
  SolveAndEstimate(&problem, &c, &pooled);
  // Redundancy numbers lie in [0, m_i] and sum to m - n (the pose group gets
  // the rest, so it checks the observations' sum).
  EXPECT_GT(c.observations.redundancy, 0.5 * static_cast<double>(c.observations.residuals));
  EXPECT_LT(c.observations.redundancy, static_cast<double>(c.observations.residuals));
  EXPECT_GT(c.pose_constraints.redundancy, 0.0);
  EXPECT_LT(c.pose_constraints.redundancy, static_cast<double>(c.pose_constraints.residuals));
  // chi2 / r has standard deviation sqrt(2 / r): ~0.02 for the observations
  // (r ~ 4 000), ~0.06 for the odometry (r ~ 650).
  EXPECT_NEAR(c.observations.factor, 1.0, 0.1);
  EXPECT_NEAR(c.pose_constraints.factor, 1.0, 0.25);
  EXPECT_NEAR(pooled, 1.0, 0.1);
}

// Odometry noise k = 3 times its stated sigma: the pooled factor is ~2.1,
// the odometry's 6-7 and the observations' 1.4 after one estimate (each
// pulled towards the other), and Foerstner's iteration reaches 9 and 1.
TEST(VarianceComponents, WideOdometryIsToldFromRightObservations) {
  const double k = 3.0;
  for (uint32_t seed : {1u, 2u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    Simulation sim;
    sim.odometry_scale = k;
    sim.seed = seed;
    core::Problem2d problem = Simulate(sim);
    VarianceComponents c;
    double pooled = 0.0;
    SolveAndEstimate(&problem, &c, &pooled);
    EXPECT_GT(pooled, 1.5);
    EXPECT_LT(pooled, 3.0);
    // One estimate already separates the groups on both sides of the pooled factor.
    EXPECT_LT(c.observations.factor, 0.75 * pooled);
    EXPECT_GT(c.pose_constraints.factor, 2.5 * pooled);
    const Eigen::Vector3d iterated = IterateComponents(problem, 4);
    EXPECT_NEAR(iterated(0), 1.0, 0.1);
    EXPECT_NEAR(iterated(1), k * k, 0.15 * k * k);
  }
}

// GPS fixes 2 times their stated sigma, odometry and observations as stated:
// the GPS group's own factor is ~4 (the GPS redundancy computed exactly).
TEST(VarianceComponents, WideGpsIsToldApart) {
  Simulation sim;
  sim.gps_every = 2;
  sim.gps_scale = 2.0;
  core::Problem2d problem = Simulate(sim);
  const Eigen::Vector3d iterated = IterateComponents(problem, 4);
  EXPECT_NEAR(iterated(0), 1.0, 0.1);
  EXPECT_NEAR(iterated(1), 1.0, 0.3);
  EXPECT_NEAR(iterated(2), 4.0, 0.2 * 4.0);
}

}  // namespace
}  // namespace graphslam::partition
