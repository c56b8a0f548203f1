// The whole GraphSLAM loop against a dense Gauss-Newton optimum, across
// backends, thread counts and chunk sizes; the fused pass against two passes
// and the chunk reads it saves.
#include "core/graphslam_solver.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <atomic>

#include "core/levenberg_marquardt.h"
#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/g2o_reader.h"
#include "tests/testing/datasets.h"
#include "tests/testing/dense_reference.h"
#include "tests/testing/heading_perturbed_problem.h"
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
  options = SolverOptions();
  options.abandon_below_rho = 1.0;
  EXPECT_TRUE(SolveGraphSlam(options, chunks, &problem, &summary).IsInvalidArgument());
}

SolverSummary SolveFromOdometry(const std::string& relative, double abandon_below_rho) {
  StatusOr<Problem2d> problem = storage::ReadG2o(graphslam::testing::DatasetPath(relative));
  EXPECT_TRUE(problem.ok()) << problem.status().ToString();
  SolverSummary summary;
  if (!problem.ok()) return summary;
  EXPECT_TRUE(InitializeProblem(&*problem).ok());
  partition::InMemoryChunkSource chunks(*problem, partition::ChunkingOptions());
  SolverOptions options;
  options.abandon_below_rho = abandon_below_rho;
  const Status status = SolveGraphSlam(options, chunks, &*problem, &summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return summary;
}

// abandon_below_rho (the probe of `graphslam solve --initialization auto`):
// Victoria Park's odometry start is outside the optimum's basin (from it LM
// ends in a local minimum, chi2 34114); its first steps show it (rho 0.22 at
// step 6). intel converges from odometry with every step well modelled.
TEST(GraphSlamSolver, AbandonsAStartWhoseQuadraticModelFails) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  const SolverSummary victoria = SolveFromOdometry("victoria_park/victoriaPark-full.g2o", 0.25);
  EXPECT_EQ(victoria.termination, "abandoned");
  EXPECT_FALSE(victoria.converged);
  ASSERT_FALSE(victoria.per_iteration.empty());
  EXPECT_LE(victoria.iterations, 10);
  EXPECT_LT(victoria.per_iteration.back().relative_decrease, 0.25);
  for (size_t k = 0; k + 1 < victoria.per_iteration.size(); ++k)
    EXPECT_GE(victoria.per_iteration[k].relative_decrease, 0.25) << "iteration " << k + 1;

  GS_REQUIRE_DATASET("freiburg_course_g2o/intel.g2o");
  const SolverSummary intel = SolveFromOdometry("freiburg_course_g2o/intel.g2o", 0.25);
  EXPECT_TRUE(intel.converged) << intel.termination;
  EXPECT_NEAR(intel.final_chi2, 359.996112, 1e-3 * 359.996112);
}

}  // namespace
}  // namespace graphslam::core

namespace graphslam::core {
namespace {

// The state is lent to the checkpoint callback (moved, not copied): the
// callback sees the full state, the solve goes on with it afterwards (same
// optimum as without checkpoints), and a callback error leaves the problem
// holding the state of that iteration rather than emptied vectors.
TEST(GraphSlamSolver, CheckpointCallbackSeesTheStateAndTheSolveKeepsIt) {
  testing::RandomProblemOptions options;
  options.num_poses = 40;
  options.num_features = 10;
  options.seed = 11;
  const testing::RandomProblem random = testing::MakeRandomProblem(options);
  partition::InMemoryChunkSource chunks(random.problem, partition::ChunkingOptions());
  SolverOptions solver_options;
  solver_options.function_tolerance = 1e-12;

  Problem2d plain = random.problem;
  SolverSummary plain_summary;
  ASSERT_TRUE(SolveGraphSlam(solver_options, chunks, &plain, &plain_summary).ok());

  std::vector<SolverCheckpoint> seen;
  solver_options.checkpoint_callback = [&](const SolverCheckpoint& c) {
    seen.push_back(c);
    return Status::Ok();
  };
  Problem2d checkpointed = random.problem;
  SolverSummary summary;
  ASSERT_TRUE(SolveGraphSlam(solver_options, chunks, &checkpointed, &summary).ok());
  // One per iteration, and the start itself first (iteration 0).
  ASSERT_EQ(static_cast<int>(seen.size()), summary.iterations + 1);
  EXPECT_EQ(seen.front().iterations, 0);
  EXPECT_EQ(seen.front().chi2, summary.initial_chi2);
  EXPECT_FALSE(seen.front().converged);
  EXPECT_EQ(seen.front().poses, random.problem.poses);
  EXPECT_EQ(summary.final_chi2, plain_summary.final_chi2);
  for (const SolverCheckpoint& c : seen) {
    ASSERT_EQ(c.poses.size(), random.problem.poses.size());
    ASSERT_EQ(c.features.size(), random.problem.features.size());
  }
  for (int j = 0; j < checkpointed.num_features(); ++j)
    EXPECT_EQ(checkpointed.features[j], plain.features[j]) << "feature " << j;

  // A failing callback at iteration 1: the error is returned and the problem
  // holds exactly the state that checkpoint was given.
  int calls = 0;
  SolverCheckpoint at_error;
  solver_options.checkpoint_callback = [&](const SolverCheckpoint& c) {
    if (++calls < 2) return Status::Ok();
    at_error = c;
    return Status::IOError("disk full (test)");
  };
  Problem2d failed = random.problem;
  EXPECT_FALSE(SolveGraphSlam(solver_options, chunks, &failed, &summary).ok());
  ASSERT_EQ(failed.features.size(), at_error.features.size());
  ASSERT_EQ(failed.poses.size(), at_error.poses.size());
  for (size_t j = 0; j < failed.features.size(); ++j)
    EXPECT_EQ(failed.features[j], at_error.features[j]) << "feature " << j;
  for (size_t i = 0; i < failed.poses.size(); ++i)
    EXPECT_EQ(failed.poses[i].x(), at_error.poses[i].x()) << "pose " << i;
}

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

namespace graphslam::core {
namespace {

// Counts Load() calls: one pass over the chunks is NumChunks() loads.
class CountingChunkSource : public ChunkSource {
 public:
  explicit CountingChunkSource(const ChunkSource& inner) : inner_(inner) {}  // must outlive
  int64_t NumChunks() const override { return inner_.NumChunks(); }
  Status Load(int64_t index, ObservationChunk* chunk) const override {
    ++loads_;
    return inner_.Load(index, chunk);
  }
  int64_t loads() const { return loads_.load(); }

 private:
  const ChunkSource& inner_;
  mutable std::atomic<int64_t> loads_{0};
};

struct CountedSolve {
  SolverSummary summary;
  std::vector<int64_t> loads;  // per iteration
  Problem2d problem;
};

CountedSolve SolveCounting(const Problem2d& problem, SolverOptions options, int64_t chunk_size) {
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = chunk_size;
  partition::InMemoryChunkSource inner(problem, chunking);
  CountingChunkSource chunks(inner);
  CountedSolve out;
  out.problem = problem;
  int64_t before = 0;
  options.iteration_callback = [&](const IterationSummary&) {
    out.loads.push_back(chunks.loads() - before);
    before = chunks.loads();
  };
  Status status = SolveGraphSlam(options, chunks, &out.problem, &out.summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  // Before the first iteration: screening (which collects the pattern of S
  // too), and the first iteration's reduce (which gives the initial chi2).
  if (!out.loads.empty()) out.loads[0] -= 2 * chunks.NumChunks();
  return out;
}

TEST(GraphSlamSolver, FusedPassReadsTheChunksOncePerWellAcceptedIteration) {
  testing::RandomProblemOptions options;
  options.num_poses = 60;
  options.num_features = 25;
  options.seed = 3;
  const Problem2d problem = testing::MakeRandomProblem(options).problem;
  SolverOptions solver_options;
  solver_options.linear_solver = LinearSolverType::kCholmod;
  solver_options.function_tolerance = 1e-14;
  solver_options.max_iterations = 25;
  const CountedSolve run = SolveCounting(problem, solver_options, 16);
  const std::vector<IterationSummary>& its = run.summary.per_iteration;
  ASSERT_EQ(run.loads.size(), its.size());
  const int64_t chunks = partition::InMemoryChunkSource(problem, [] {
                           partition::ChunkingOptions c;
                           c.max_observations_per_chunk = 16;
                           return c;
                         }()).NumChunks();
  ASSERT_GT(chunks, 4);
  int one_pass = 0;
  int64_t total = 0;
  for (size_t i = 0; i < its.size(); ++i) {
    // The solver's own count is the truth of the ChunkSource.
    EXPECT_EQ(run.loads[i], its[i].chunk_passes * chunks) << "iteration " << i + 1;
    total += run.loads[i];
    if (i == 0) {
      EXPECT_EQ(its[i].chunk_passes, 1);  // its reduce ran before it, for the initial chi2
      continue;
    }
    // The previous iteration speculated unless the one before it had a
    // rejected step (core/levenberg_marquardt.h).
    const IterationSummary& previous = its[i - 1];
    const bool speculated = i == 1 || its[i - 2].accepted;
    if (speculated && previous.accepted && previous.relative_decrease > kSpeculationRho + 1e-6) {
      EXPECT_EQ(run.loads[i], chunks) << "iteration " << i + 1 << " after rho "
                                      << previous.relative_decrease;
      ++one_pass;
    } else if (!previous.accepted || !speculated) {
      EXPECT_EQ(run.loads[i], 2 * chunks) << "iteration " << i + 1;
    }
  }
  EXPECT_GE(one_pass, 3) << its.size() << " iterations";
  EXPECT_LT(total, 2 * chunks * static_cast<int64_t>(its.size()));
}

// Every iteration solves the very system two passes would: the same trace and
// the same optimum, bit for bit, with rejected steps and mid-range rho too.
TEST(GraphSlamSolver, FusedPassGivesTheTwoPassResultBitForBit) {
  int rejected = 0, mid_rho = 0, one_pass = 0, one_pass_after_mid_rho = 0;
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    for (double radius : {1e4, 1e12}) {
      // Headings off by up to 2.5 rad: far from the quadratic regime, so
      // some steps are rejected and some accepted with a modest rho (with
      // 1 rad the only rejections were round-off steps at the optimum).
      testing::HeadingPerturbation perturbation;
      perturbation.seed = seed;
      perturbation.gps_every = seed % 2 == 0 ? 5 : 0;
      Problem2d problem = testing::HeadingPerturbedProblem(perturbation);
      SolverOptions solver_options;
      solver_options.function_tolerance = 1e-12;
      solver_options.max_iterations = 30;
      solver_options.initial_trust_region_radius = radius;
      if (seed == 3) {
        solver_options.observation_kernel.type = RobustKernel::Type::kCauchy;
        solver_options.max_eliminated_observations = 4;  // kept features too
      }
      const CountedSolve fused = SolveCounting(problem, solver_options, 8);
      solver_options.fused_chunk_pass = false;
      const CountedSolve two_pass = SolveCounting(problem, solver_options, 8);
      const std::vector<IterationSummary>& a = fused.summary.per_iteration;
      const std::vector<IterationSummary>& b = two_pass.summary.per_iteration;
      ASSERT_EQ(a.size(), b.size()) << "seed " << seed << " radius " << radius;
      for (size_t i = 0; i < a.size(); ++i) {
        EXPECT_EQ(a[i].chi2, b[i].chi2) << "seed " << seed << " iteration " << i + 1;
        EXPECT_EQ(a[i].candidate_chi2, b[i].candidate_chi2);
        EXPECT_EQ(a[i].lambda, b[i].lambda);
        EXPECT_EQ(a[i].accepted, b[i].accepted);
        // A rejected full step may take a third pass: the line search's chi2.
        const bool searched = b[i].line_search_fraction > 0.0 || !b[i].accepted;
        EXPECT_EQ(b[i].chunk_passes, searched && b[i].chunk_passes == 3 ? 3 : 2);
        rejected += !a[i].accepted;
        mid_rho += a[i].accepted && a[i].relative_decrease < 0.9;
        one_pass += a[i].chunk_passes == 1;
        // Iteration i reused the system iteration i - 1 reduced ahead, which
        // it did after the accepted step of mid-range rho of iteration i - 2.
        one_pass_after_mid_rho += i >= 2 && a[i].chunk_passes == 1 && a[i - 2].accepted &&
                                  a[i - 2].relative_decrease < kSpeculationRho;
      }
      EXPECT_EQ(fused.summary.final_chi2, two_pass.summary.final_chi2);
      EXPECT_EQ(fused.summary.termination, two_pass.summary.termination);
      testing::ExpectBitIdenticalEstimates(fused.problem, two_pass.problem);
    }
  }
  // Both paths of the speculation were taken.
  EXPECT_GT(rejected, 0);
  EXPECT_GT(mid_rho, 0);
  EXPECT_GT(one_pass, 10);
  // Speculation goes on after a step that fitted poorly (the next one mostly fits).
  EXPECT_GT(one_pass_after_mid_rho, 0);
}

// A rejected step's line search reduces ahead at x (+) t d in its own pass:
// after an accepted line step the next iteration reads the chunks once, and
// the trace and optimum are those of the two-pass solver, bit for bit.
TEST(GraphSlamSolver, LineSearchPassReducesAheadBitForBit) {
  int line_steps = 0, reduced_by_the_line_pass = 0;
  for (uint32_t seed = 1; seed <= 12; ++seed) {
    testing::HeadingPerturbation perturbation;
    perturbation.seed = seed;
    perturbation.feature_offset_m = 20.0;
    Problem2d problem = testing::HeadingPerturbedProblem(perturbation);
    SolverOptions solver_options;
    solver_options.function_tolerance = 1e-12;
    solver_options.max_iterations = 30;
    const CountedSolve fused = SolveCounting(problem, solver_options, 8);
    solver_options.fused_chunk_pass = false;
    const CountedSolve two_pass = SolveCounting(problem, solver_options, 8);
    const std::vector<IterationSummary>& a = fused.summary.per_iteration;
    const std::vector<IterationSummary>& b = two_pass.summary.per_iteration;
    ASSERT_EQ(a.size(), b.size()) << "seed " << seed;
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_EQ(a[i].chi2, b[i].chi2) << "seed " << seed << " iteration " << i + 1;
      EXPECT_EQ(a[i].lambda, b[i].lambda);
      EXPECT_EQ(a[i].line_search_fraction, b[i].line_search_fraction);
      if (i >= 1 && a[i - 1].accepted && a[i - 1].line_search_fraction > 0.0) {
        ++line_steps;
        reduced_by_the_line_pass += a[i].chunk_passes == b[i].chunk_passes - 1;
      }
    }
    EXPECT_EQ(fused.summary.final_chi2, two_pass.summary.final_chi2);
    testing::ExpectBitIdenticalEstimates(fused.problem, two_pass.problem);
  }
  EXPECT_GT(line_steps, 0);
  EXPECT_EQ(reduced_by_the_line_pass, line_steps);
}

}  // namespace
}  // namespace graphslam::core
