// Tests for partition/initialization/sampled_incremental_initialization.h: the
// streaming start from a feature sample, on a simulated dense GPS campus
// store, sampled well below one (as a 10^7-feature store is by default).
#include "partition/initialization/sampled_incremental_initialization.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>

#include "core/graphslam_solver.h"
#include "storage/chunk_store.h"
#include "tests/testing/dense_campus_store.h"

namespace graphslam::partition {
namespace {

namespace fs = std::filesystem;

TEST(SampledIncrementalInitialization, FeatureKeysAreUniform) {
  int below_quarter = 0;
  const int n = 100000;
  for (int32_t f = 0; f < n; ++f) {
    const double key = FeatureSampleKey(f);
    ASSERT_GE(key, 0.0);
    ASSERT_LT(key, 1.0);
    if (key < 0.25) ++below_quarter;
  }
  // Binomial(n, 1/4): standard deviation 137.
  EXPECT_NEAR(below_quarter, n / 4, 700);
}

// A campus of 1 000 poses x 2 runs at 10^6 features (~360 observations per
// pose, odometry drifting ~0.03 rad per pose, GPS every 50 poses), sampled at
// about 40 observations per pose: the whole problem's solve from that start
// reaches chi2/dof 1 (the optimum of this simulated data, within
// sqrt(2 / dof) = 0.002 of it). From the pose-graph start the same solve
// is still at chi2/dof 3.0 after 100 iterations.
TEST(SampledIncrementalInitialization, SampledStartThenSolveReachesTheOptimum) {
  const fs::path root = fs::temp_directory_path() /
                        ("graphslam_sampled_init_" + std::to_string(getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  const std::string store =
      testing::SimulateDenseCampusStore(root.string(), "", 1000, 2, 1000000);
  ASSERT_FALSE(store.empty());

  StatusOr<std::unique_ptr<storage::DiskChunkSource>> chunks =
      storage::DiskChunkSource::Open(store);
  ASSERT_TRUE(chunks.ok()) << chunks.status().ToString();
  StatusOr<core::Problem2d> problem = storage::ReadChunkStoreProblem(store);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  const int64_t observations = (*chunks)->total_observations();
  ASSERT_GT(observations, 300000);

  SampledInitializationOptions options;
  options.min_observations = 0;
  options.observations_per_pose = 40;
  SampledInitializationSummary summary;
  const core::SolverOptions solver;
  ASSERT_TRUE(InitializeFromSampledFeatures(options, solver, **chunks, observations, &*problem,
                                            &summary)
                  .ok());
  const double budget = 40.0 * problem->num_poses();
  EXPECT_NEAR(summary.rate, budget / static_cast<double>(observations), 1e-12);
  EXPECT_LT(summary.rate, 0.15);
  // The sample holds about the budget (a feature's observations come whole).
  EXPECT_GT(summary.sampled_observations, 0.8 * budget);
  EXPECT_LT(summary.sampled_observations, 1.2 * budget);
  EXPECT_EQ(summary.placed_features, (*chunks)->total_features());
  EXPECT_EQ(summary.budget_observations, 40 * problem->num_poses());
  EXPECT_FALSE(summary.capped);

  core::SolverSummary solved;
  ASSERT_TRUE(core::SolveGraphSlam(solver, **chunks, &*problem, &solved).ok());
  EXPECT_TRUE(solved.converged) << solved.termination;
  // Residual dimension minus unknowns: 2 per observation and GPS fix, 3 per
  // odometry edge; 3 per pose but the fixed ones, 2 per observed feature.
  double dof = 2.0 * static_cast<double>(observations) +
               3.0 * static_cast<double>(problem->relative_poses.size() +
                                         problem->motions.size()) +
               2.0 * static_cast<double>(problem->gps.size()) -
               2.0 * static_cast<double>(summary.placed_features);
  for (int32_t p = 0; p < problem->num_poses(); ++p)
    if (!problem->pose_fixed[p]) dof -= 3.0;
  ASSERT_GT(dof, 100000.0);
  EXPECT_NEAR(solved.final_chi2 / dof, 1.0, 0.01);
  fs::remove_all(root);
}

// B given outright, and a cap below it (a memory limit's share): the cap
// wins and bounds what the sample holds.
TEST(SampledIncrementalInitialization, BudgetGivenOrCapped) {
  const fs::path root = fs::temp_directory_path() /
                        ("graphslam_sampled_budget_" + std::to_string(getpid()));
  fs::remove_all(root);
  fs::create_directories(root);
  const std::string store = testing::SimulateDenseCampusStore(root.string(), "", 300, 2, 100000);
  ASSERT_FALSE(store.empty());
  StatusOr<std::unique_ptr<storage::DiskChunkSource>> chunks =
      storage::DiskChunkSource::Open(store);
  ASSERT_TRUE(chunks.ok()) << chunks.status().ToString();
  StatusOr<core::Problem2d> problem = storage::ReadChunkStoreProblem(store);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  const int64_t observations = (*chunks)->total_observations();
  ASSERT_GT(observations, 50000);

  for (const int64_t cap : {int64_t{-1}, int64_t{8000}}) {
    SCOPED_TRACE("cap " + std::to_string(cap));
    core::Problem2d copy = *problem;
    SampledInitializationOptions options;
    options.budget_observations = 20000;
    options.max_observations = cap;
    options.sub_solve_iterations = 2;
    SampledInitializationSummary summary;
    ASSERT_TRUE(InitializeFromSampledFeatures(options, core::SolverOptions(), **chunks,
                                              observations, &copy, &summary)
                    .ok());
    const int64_t budget = cap < 0 ? 20000 : cap;
    EXPECT_EQ(summary.budget_observations, budget);
    EXPECT_EQ(summary.capped, cap >= 0);
    EXPECT_NEAR(summary.rate, static_cast<double>(budget) / static_cast<double>(observations),
                1e-12);
    EXPECT_GT(summary.sampled_observations, 0.7 * static_cast<double>(budget));
    EXPECT_LT(summary.sampled_observations, 1.3 * static_cast<double>(budget));
  }
  fs::remove_all(root);
}

}  // namespace
}  // namespace graphslam::partition
