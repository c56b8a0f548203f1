// Tests for partition/initialization/sampled_incremental_initialization.h: the
// streaming start from a feature sample, on a simulated dense GPS campus
// store, sampled well below one (as a 10^7-feature store is by default).
#include "partition/initialization/sampled_incremental_initialization.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <utility>

#include "core/graphslam_solver.h"
#include "storage/chunk_store.h"
#include "tests/testing/dense_campus_store.h"

namespace graphslam::partition {
namespace {

namespace fs = std::filesystem;

// A simulated dense campus store (2 runs) in a fresh temporary folder,
// opened; the folder goes with it.
struct CampusStore {
  fs::path root;
  std::unique_ptr<storage::DiskChunkSource> chunks;
  core::Problem2d problem;
  ~CampusStore() { fs::remove_all(root); }
};

void OpenCampusStore(const std::string& tag, int64_t poses, int64_t features, CampusStore* out) {
  out->root = fs::temp_directory_path() /
              ("graphslam_sampled_" + tag + "_" + std::to_string(getpid()));
  fs::remove_all(out->root);
  fs::create_directories(out->root);
  const std::string store =
      testing::SimulateDenseCampusStore(out->root.string(), "", poses, 2, features);
  ASSERT_FALSE(store.empty());
  StatusOr<std::unique_ptr<storage::DiskChunkSource>> chunks =
      storage::DiskChunkSource::Open(store);
  ASSERT_TRUE(chunks.ok()) << chunks.status().ToString();
  out->chunks = std::move(*chunks);
  StatusOr<core::Problem2d> problem = storage::ReadChunkStoreProblem(store);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  out->problem = std::move(*problem);
}

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
  CampusStore campus;
  ASSERT_NO_FATAL_FAILURE(OpenCampusStore("init", 1000, 1000000, &campus));
  const std::unique_ptr<storage::DiskChunkSource>& chunks = campus.chunks;
  core::Problem2d* problem = &campus.problem;
  const int64_t observations = chunks->total_observations();
  ASSERT_GT(observations, 300000);

  SampledInitializationOptions options;
  options.min_observations = 0;
  options.observations_per_pose = 40;
  SampledInitializationSummary summary;
  const core::SolverOptions solver;
  ASSERT_TRUE(InitializeFromSampledFeatures(options, solver, *chunks, observations, problem,
                                            &summary)
                  .ok());
  const double budget = 40.0 * problem->num_poses();
  EXPECT_NEAR(summary.rate, budget / static_cast<double>(observations), 1e-12);
  EXPECT_LT(summary.rate, 0.15);
  // The sample holds about the budget (a feature's observations come whole).
  EXPECT_GT(summary.sampled_observations, 0.8 * budget);
  EXPECT_LT(summary.sampled_observations, 1.2 * budget);
  EXPECT_EQ(summary.placed_features, chunks->total_features());
  EXPECT_EQ(summary.budget_observations, 40 * problem->num_poses());
  EXPECT_FALSE(summary.capped);

  core::SolverSummary solved;
  ASSERT_TRUE(core::SolveGraphSlam(solver, *chunks, problem, &solved).ok());
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
}

// The sample's solve stops at its own function tolerance: a loose one ends
// it earlier than a tight one, from the same sampled start, and a negative
// one is refused.
TEST(SampledIncrementalInitialization, SampleSolveStopsAtItsOwnFunctionTolerance) {
  CampusStore campus;
  ASSERT_NO_FATAL_FAILURE(OpenCampusStore("tolerance", 300, 100000, &campus));
  const int64_t observations = campus.chunks->total_observations();
  SampledInitializationSummary tight_summary;
  SampledInitializationSummary loose_summary;
  for (const double tolerance : {1e-12, 1e-1}) {
    core::Problem2d copy = campus.problem;
    SampledInitializationOptions options;
    options.budget_observations = 20000;
    options.sub_solve_function_tolerance = tolerance;
    SampledInitializationSummary& summary = tolerance < 1e-6 ? tight_summary : loose_summary;
    ASSERT_TRUE(InitializeFromSampledFeatures(options, core::SolverOptions(), *campus.chunks,
                                              observations, &copy, &summary)
                    .ok());
  }
  ASSERT_GT(tight_summary.sub_solve_iterations, 1);
  EXPECT_LT(loose_summary.sub_solve_iterations, tight_summary.sub_solve_iterations);
  EXPECT_EQ(loose_summary.sub_solve_initial_chi2, tight_summary.sub_solve_initial_chi2);
  EXPECT_GE(loose_summary.sub_solve_final_chi2, tight_summary.sub_solve_final_chi2);

  core::Problem2d copy = campus.problem;
  SampledInitializationOptions options;
  options.sub_solve_function_tolerance = -1.0;
  SampledInitializationSummary summary;
  EXPECT_TRUE(InitializeFromSampledFeatures(options, core::SolverOptions(), *campus.chunks,
                                            observations, &copy, &summary)
                  .IsInvalidArgument());
}

// B given outright, and a cap below it (a memory limit's share): the cap
// wins and bounds what the sample holds.
TEST(SampledIncrementalInitialization, BudgetGivenOrCapped) {
  CampusStore campus;
  ASSERT_NO_FATAL_FAILURE(OpenCampusStore("budget", 300, 100000, &campus));
  const int64_t observations = campus.chunks->total_observations();
  ASSERT_GT(observations, 50000);

  for (const int64_t cap : {int64_t{-1}, int64_t{8000}}) {
    SCOPED_TRACE("cap " + std::to_string(cap));
    core::Problem2d copy = campus.problem;
    SampledInitializationOptions options;
    options.budget_observations = 20000;
    options.max_observations = cap;
    options.sub_solve_iterations = 2;
    SampledInitializationSummary summary;
    ASSERT_TRUE(InitializeFromSampledFeatures(options, core::SolverOptions(), *campus.chunks,
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
}

// The start frees the whole problem's estimates while its stages run and
// keeps the guesses of features no chunk observes: a feature added to the
// problem (in no chunk) comes back at its guess, every other estimate is
// placed as before, and with the ids parked (feature_ids empty, as the
// streaming solve does) the start is the same to the bit.
TEST(SampledIncrementalInitialization, UnobservedGuessesKeptAndParkedIdsChangeNothing) {
  CampusStore campus;
  ASSERT_NO_FATAL_FAILURE(OpenCampusStore("unobserved", 300, 100000, &campus));
  const int64_t observations = campus.chunks->total_observations();
  const core::Point2 guess(7.25, -3.5);
  campus.problem.AddFeature(int64_t{1} << 40, guess, true);
  const int32_t unobserved = campus.problem.num_features() - 1;
  SampledInitializationOptions options;
  options.budget_observations = 20000;
  options.sub_solve_iterations = 3;
  core::Problem2d with_ids = campus.problem;
  core::Problem2d parked = campus.problem;
  parked.feature_ids.clear();
  SampledInitializationSummary with_ids_summary;
  SampledInitializationSummary parked_summary;
  ASSERT_TRUE(InitializeFromSampledFeatures(options, core::SolverOptions(), *campus.chunks,
                                            observations, &with_ids, &with_ids_summary)
                  .ok());
  ASSERT_TRUE(InitializeFromSampledFeatures(options, core::SolverOptions(), *campus.chunks,
                                            observations, &parked, &parked_summary)
                  .ok());
  ASSERT_LT(with_ids_summary.rate, 1.0);
  EXPECT_EQ(with_ids_summary.placed_features, campus.chunks->total_features());
  ASSERT_EQ(with_ids.num_features(), campus.problem.num_features());
  EXPECT_EQ(with_ids.features[unobserved], guess);
  // Observed features were all placed anew (the campus's guesses differ).
  int64_t moved = 0;
  for (int32_t f = 0; f < unobserved; ++f)
    moved += with_ids.features[f] != campus.problem.features[f] ? 1 : 0;
  EXPECT_GT(moved, unobserved / 2);
  EXPECT_EQ(with_ids.feature_ids, campus.problem.feature_ids);
  EXPECT_EQ(parked_summary.sub_solve_final_chi2, with_ids_summary.sub_solve_final_chi2);
  ASSERT_EQ(parked.num_features(), with_ids.num_features());
  for (int32_t f = 0; f < parked.num_features(); ++f)
    ASSERT_EQ(parked.features[f], with_ids.features[f]) << "feature " << f;
  for (int32_t p = 0; p < parked.num_poses(); ++p)
    ASSERT_EQ(parked.poses[p], with_ids.poses[p]) << "pose " << p;
}

}  // namespace
}  // namespace graphslam::partition
