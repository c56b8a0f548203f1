// The whole GraphSLAM loop against a dense Gauss-Newton optimum, across
// backends, thread counts and chunk sizes.
#include "core/graphslam_solver.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include "partition/in_memory_chunk_source.h"
#include "tests/testing/dense_reference.h"
#include "tests/testing/random_problem.h"

namespace graphslam::core {
namespace {

SolverSummary Solve(Problem2d* problem, LinearSolverType type, int64_t chunk_size,
                    int max_iterations = 100) {
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = chunk_size;
  partition::InMemoryChunkSource chunks(*problem, chunking);
  SolverOptions options;
  options.linear_solver = type;
  options.max_iterations = max_iterations;
  options.function_tolerance = 1e-12;
  SolverSummary summary;
  Status status = SolveGraphSlam(options, chunks, problem, &summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return summary;
}

class GraphSlamSolverTest
    : public ::testing::TestWithParam<std::tuple<LinearSolverType, bool, bool>> {};

TEST_P(GraphSlamSolverTest, ReachesDenseGaussNewtonOptimum) {
  const auto [type, range_bearing, velocity] = GetParam();
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    testing::RandomProblemOptions options;
    options.seed = seed;
    options.range_bearing = range_bearing;
    options.velocity_motion = velocity;
    options.num_poses = 20;
    options.num_features = 8;
    testing::RandomProblem random = testing::MakeRandomProblem(options);
    Problem2d reference_problem = random.problem;
    testing::DenseReference dense(reference_problem);
    const double dense_optimum = dense.Chi2(dense.SolveGaussNewton(50));

    SolverSummary summary = Solve(&random.problem, type, 5);
    EXPECT_TRUE(summary.converged) << summary.termination;
    EXPECT_NEAR(summary.final_chi2, dense_optimum, 1e-6 * dense_optimum)
        << "seed " << seed << " initial " << summary.initial_chi2;
    EXPECT_LT(summary.final_chi2, summary.initial_chi2);
    // The chi2 the solver reports is the chi2 of the state it returns.
    testing::DenseReference after(random.problem);
    EXPECT_NEAR(after.Chi2(after.State()), summary.final_chi2, 1e-9 * summary.final_chi2);
  }
}

INSTANTIATE_TEST_SUITE_P(
    BackendsAndModels, GraphSlamSolverTest,
    ::testing::Combine(::testing::Values(LinearSolverType::kCholmod, LinearSolverType::kPcg),
                       ::testing::Bool(), ::testing::Bool()));

TEST(GraphSlamSolver, ParallelEqualsSerialBitForBit) {
  testing::RandomProblemOptions options;
  options.num_poses = 200;
  options.num_features = 60;
  options.seed = 7;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  Problem2d serial = random.problem, parallel = random.problem;
  SolverSummary serial_summary, parallel_summary;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    serial_summary = Solve(&serial, LinearSolverType::kCholmod, 16, 10);
  }
  {
    tbb::global_control many(tbb::global_control::max_allowed_parallelism, 4);
    parallel_summary = Solve(&parallel, LinearSolverType::kCholmod, 16, 10);
  }
  EXPECT_EQ(serial_summary.final_chi2, parallel_summary.final_chi2);
  for (int p = 0; p < serial.num_poses(); ++p)
    EXPECT_EQ((serial.poses[p] - parallel.poses[p]).norm(), 0.0) << "pose " << p;
  for (int j = 0; j < serial.num_features(); ++j)
    EXPECT_EQ((serial.features[j] - parallel.features[j]).norm(), 0.0) << "feature " << j;
}

TEST(GraphSlamSolver, ChunkSizeDoesNotChangeTheResult) {
  testing::RandomProblemOptions options;
  options.num_poses = 60;
  options.num_features = 25;
  options.seed = 3;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  Problem2d small = random.problem, large = random.problem;
  const SolverSummary a = Solve(&small, LinearSolverType::kCholmod, 1);
  const SolverSummary b = Solve(&large, LinearSolverType::kCholmod, 1 << 20);
  EXPECT_NEAR(a.final_chi2, b.final_chi2, 1e-9 * b.final_chi2);
}

TEST(GraphSlamSolver, GpsAnchorsTheMapWithoutAFixedPose) {
  testing::RandomProblemOptions options;
  options.num_poses = 40;
  options.num_features = 10;
  options.gps_every = 5;
  options.seed = 11;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  Problem2d reference_problem = random.problem;
  testing::DenseReference dense(reference_problem);
  EXPECT_EQ(dense.layout().num_anchored, 0);
  const double dense_optimum = dense.Chi2(dense.SolveGaussNewton(50));
  const SolverSummary summary = Solve(&random.problem, LinearSolverType::kCholmod, 8);
  EXPECT_EQ(summary.unknown_poses, 40);
  EXPECT_NEAR(summary.final_chi2, dense_optimum, 1e-6 * dense_optimum);
  // GPS ties the map to the world frame: poses land near the truth.
  double error = 0.0;
  for (int p = 0; p < 40; ++p)
    error += (random.problem.poses[p].head<2>() - random.true_poses[p].head<2>()).squaredNorm();
  EXPECT_LT(std::sqrt(error / 40), 0.5);
}

TEST(GraphSlamSolver, RejectsInvalidOptions) {
  Problem2d problem;
  partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
  SolverOptions options;
  options.max_iterations = -1;
  SolverSummary summary;
  EXPECT_TRUE(SolveGraphSlam(options, chunks, &problem, &summary).IsInvalidArgument());
}

}  // namespace
}  // namespace graphslam::core

namespace graphslam::core {
namespace {

TEST(GraphSlamSolver, KeepingFeaturesAsUnknownsEqualsEliminatingThem) {
  testing::RandomProblemOptions options;
  options.num_poses = 50;
  options.num_features = 12;
  options.seed = 5;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  Problem2d eliminated = random.problem, kept = random.problem;
  for (LinearSolverType type : {LinearSolverType::kCholmod, LinearSolverType::kPcg}) {
    partition::InMemoryChunkSource chunks(random.problem, partition::ChunkingOptions());
    SolverOptions solver_options;
    solver_options.linear_solver = type;
    solver_options.function_tolerance = 1e-12;
    SolverSummary a, b;
    Problem2d x = eliminated, y = kept;
    ASSERT_TRUE(SolveGraphSlam(solver_options, chunks, &x, &a).ok());
    solver_options.max_eliminated_observations = 3;  // most features are kept
    ASSERT_TRUE(SolveGraphSlam(solver_options, chunks, &y, &b).ok());
    EXPECT_EQ(a.kept_features, 0);
    EXPECT_GT(b.kept_features, 6);
    EXPECT_EQ(b.kept_features + b.eliminated_features, 12);
    EXPECT_LT(b.reduced_nonzero_blocks, a.reduced_nonzero_blocks);
    EXPECT_NEAR(a.final_chi2, b.final_chi2, 1e-8 * a.final_chi2) << LinearSolverName(type);
    for (int j = 0; j < x.num_features(); ++j)
      EXPECT_LT((x.features[j] - y.features[j]).norm(), 1e-6) << "feature " << j;
  }
}

TEST(GraphSlamSolver, RobustKernelResistsAGrossOutlier) {
  testing::RandomProblemOptions options;
  options.num_poses = 40;
  options.num_features = 10;
  options.seed = 9;
  options.perturb_initial = false;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  // Corrupt a few range-bearing observations of feature 0 (a misread barcode).
  int corrupted = 0;
  for (Observation& o : random.problem.observations) {
    if (o.feature == 0 && corrupted < 3) {
      o.z.y() = WrapAngle(o.z.y() + 2.0);
      ++corrupted;
    }
  }
  ASSERT_EQ(corrupted, 3);
  auto feature_error = [&](const RobustKernel& kernel) {
    Problem2d problem = random.problem;
    partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
    SolverOptions solver_options;
    solver_options.observation_kernel = kernel;
    SolverSummary summary;
    EXPECT_TRUE(SolveGraphSlam(solver_options, chunks, &problem, &summary).ok());
    return (problem.features[0] - random.true_features[0]).norm();
  };
  const double plain = feature_error(RobustKernel());
  RobustKernel cauchy;
  cauchy.type = RobustKernel::Type::kCauchy;
  cauchy.scale = 2.0;
  const double robust = feature_error(cauchy);
  EXPECT_LT(robust, 0.25);
  EXPECT_LT(robust, 0.5 * plain) << "plain " << plain << " robust " << robust;
}

}  // namespace
}  // namespace graphslam::core

namespace graphslam::core {
namespace {

TEST(GraphSlamSolver, IncompleteCholeskyPcgReachesTheCholmodOptimum) {
  testing::RandomProblemOptions options;
  options.num_poses = 80;
  options.num_features = 20;
  options.seed = 13;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  Problem2d direct = random.problem, iterative = random.problem;
  partition::InMemoryChunkSource chunks(random.problem, partition::ChunkingOptions());
  SolverOptions solver_options;
  solver_options.function_tolerance = 1e-12;
  solver_options.linear_solver = LinearSolverType::kCholmod;
  SolverSummary a, b;
  ASSERT_TRUE(SolveGraphSlam(solver_options, chunks, &direct, &a).ok());
  solver_options.linear_solver = LinearSolverType::kPcg;
  solver_options.preconditioner = PreconditionerType::kIncompleteCholesky;
  ASSERT_TRUE(SolveGraphSlam(solver_options, chunks, &iterative, &b).ok());
  EXPECT_EQ(b.linear_solver_used, LinearSolverType::kPcg);
  EXPECT_NEAR(a.final_chi2, b.final_chi2, 1e-8 * a.final_chi2);
  EXPECT_TRUE(ParsePreconditionerType("jacobi").status().IsInvalidArgument());
}

}  // namespace
}  // namespace graphslam::core
