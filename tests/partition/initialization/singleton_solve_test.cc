// SolveWithoutSingletons (partition/initialization/singleton_solve.h): leaving features seen
// once out of the solve gives the optimum of the full solve, places them
// exactly, and avoids the rejected steps their linear recovery causes.
#include "partition/initialization/singleton_solve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "core/initialization.h"
#include "core/range_bearing_model.h"
#include "core/unidentified_features.h"
#include "tests/testing/random_problem.h"
#include "tests/testing/tight_solver_options.h"

namespace graphslam::partition {
namespace {

core::SolverOptions TightOptions() { return testing::TightCholmodSolverOptions(); }

// Gives every observation whose index is a multiple of `every` a feature of
// its own (every = 1: an id-less problem, every feature seen once).
void MakeSingletons(int every, core::Problem2d* problem) {
  for (size_t o = 0; o < problem->observations.size(); o += every) {
    problem->observations[o].feature =
        problem->AddFeature(core::kNoFeatureId, core::Point2::Zero(), false);
  }
}

int CountRejected(const core::SolverSummary& summary) {
  return static_cast<int>(std::count_if(summary.per_iteration.begin(), summary.per_iteration.end(),
                                        [](const auto& it) { return !it.accepted; }));
}

TEST(SingletonSolve, ReachesTheOptimumOfTheFullSolveAndPlacesSingletonsExactly) {
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    testing::RandomProblemOptions random_options;
    random_options.seed = seed;
    random_options.gps_every = 4;
    testing::RandomProblem random = testing::MakeRandomProblem(random_options);
    core::Problem2d problem = random.problem;
    MakeSingletons(3, &problem);
    ASSERT_TRUE(core::InitializeProblem(&problem).ok());

    core::Problem2d full = problem;
    core::SolverSummary full_summary;
    InMemoryChunkSource chunks(full, ChunkingOptions());
    ASSERT_TRUE(core::SolveGraphSlam(TightOptions(), chunks, &full, &full_summary).ok());

    core::SolverSummary summary;
    int64_t singletons = 0;
    ASSERT_TRUE(
        SolveWithoutSingletons(TightOptions(), ChunkingOptions(), &problem, &summary, &singletons)
            .ok());
    EXPECT_GT(singletons, 10);
    EXPECT_NEAR(summary.final_chi2, full_summary.final_chi2, 1e-8 * full_summary.final_chi2);
    for (int p = 0; p < problem.num_poses(); ++p)
      EXPECT_LT((problem.poses[p] - full.poses[p]).norm(), 1e-6) << "pose " << p;
    for (int f = 0; f < problem.num_features(); ++f)
      EXPECT_LT((problem.features[f] - full.features[f]).norm(), 1e-6) << "feature " << f;
    // Singletons sit exactly where their observation puts them.
    std::vector<int> count(problem.num_features(), 0);
    for (const core::Observation& o : problem.observations) ++count[o.feature];
    for (const core::Observation& o : problem.observations) {
      if (count[o.feature] != 1) continue;
      Eigen::Vector2d e;
      ASSERT_TRUE(core::EvaluateRangeBearing(problem.poses[o.pose], problem.features[o.feature],
                                             o.z, &e, nullptr, nullptr));
      EXPECT_LT(e.norm(), 1e-12);
    }

    // Releasing the observations once chunked changes nothing but them.
    core::Problem2d released = random.problem;
    MakeSingletons(3, &released);
    ASSERT_TRUE(core::InitializeProblem(&released).ok());
    core::SolverSummary released_summary;
    ASSERT_TRUE(SolveWithoutSingletons(TightOptions(), ChunkingOptions(), &released,
                                       &released_summary, nullptr, true)
                    .ok());
    EXPECT_TRUE(released.observations.empty());
    EXPECT_EQ(released_summary.final_chi2, summary.final_chi2);
    EXPECT_EQ(released.poses, problem.poses);
    EXPECT_EQ(released.features, problem.features);
  }
}

// The failure this fixes, small: an id-less problem (every feature a
// singleton) with GPS, started with the trajectory bent by a heading error.
// Kept in the solve, the singletons' linear recovery misses by about
// r dtheta^2 / 2 and the pose steps are rejected; left out, the problem is the
// pose graph it really is. Measured: kept in, 24 iterations of which 7
// rejected; left out, 8 iterations, none rejected; the same chi2 20.2243438.
TEST(SingletonSolve, IdLessProblemConvergesWithoutRejectedSteps) {
  testing::RandomProblemOptions random_options;
  random_options.num_poses = 60;
  random_options.num_features = 20;
  random_options.gps_every = 5;
  random_options.seed = 9;
  testing::RandomProblem random = testing::MakeRandomProblem(random_options);
  core::Problem2d problem = random.problem;
  MakeSingletons(1, &problem);
  ASSERT_TRUE(core::InitializeProblem(&problem).ok());
  // Bend the initial trajectory: heading error growing 0.02 rad per pose.
  for (int p = 1; p < problem.num_poses(); ++p) {
    const core::Pose2& previous = problem.poses[p - 1];
    const core::Pose2 step = core::Between(random.true_poses[p - 1], random.true_poses[p]);
    problem.poses[p] = core::Compose(previous, core::Pose2(step.x(), step.y(), step.z() + 0.02));
  }
  for (const core::Observation& o : problem.observations)
    problem.features[o.feature] = core::InvertRangeBearing(problem.poses[o.pose], o.z);
  core::SolverOptions options = TightOptions();
  options.max_iterations = 100;

  core::Problem2d kept_in = problem;
  core::SolverSummary kept_summary;
  InMemoryChunkSource chunks(kept_in, ChunkingOptions());
  ASSERT_TRUE(core::SolveGraphSlam(options, chunks, &kept_in, &kept_summary).ok());

  core::SolverSummary summary;
  ASSERT_TRUE(SolveWithoutSingletons(options, ChunkingOptions(), &problem, &summary).ok());
  EXPECT_TRUE(summary.converged) << summary.termination;
  EXPECT_EQ(CountRejected(summary), 0);
  EXPECT_GT(CountRejected(kept_summary), 0);
  EXPECT_LT(summary.iterations, kept_summary.iterations);
  EXPECT_LE(summary.final_chi2, kept_summary.final_chi2 * (1 + 1e-9));
}

}  // namespace
}  // namespace graphslam::partition
