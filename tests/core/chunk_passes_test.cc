// The chunked reduce and recover passes against the dense Schur complement of
// the whole information matrix (H by central differences of the stacked
// residuals, independent of the analytic Jacobians).
#include "core/chunk_passes.h"

#include <gtest/gtest.h>

#include "core/internal/chunk_pass_kernels.h"
#include "core/internal/pose_pair_set.h"
#include "core/pose_factors.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/dense_reference.h"
#include "tests/testing/reduced_system_at.h"
#include "tests/testing/random_problem.h"

namespace graphslam::core {
namespace {

struct Reduced {
  Eigen::MatrixXd matrix;
  Eigen::VectorXd rhs;
  Eigen::VectorXd gradient;
};

Reduced RunReduce(const Problem2d& problem, const ChunkSource& chunks, const UnknownLayout& layout,
                  double lambda) {
  PassContext context;
  context.chunks = &chunks;
  context.layout = &layout;
  std::vector<std::pair<int, int>> pairs;
  AppendPoseFactorPattern(problem, layout, &pairs);
  EXPECT_TRUE(CollectReducedPattern(context, &pairs).ok());
  ReducedSystem system;
  system.matrix = BlockSparseMatrix::FromPattern(3, layout.num_unknown_poses, pairs);
  const int n = system.matrix.num_rows();
  system.matrix.SetZero();
  system.rhs.setZero(n);
  system.gradient.setZero(n);
  system.hessian_diagonal.setZero(n);
  LinearizePoseFactors(problem, problem.poses, layout, &system.matrix, &system.gradient,
                       &system.hessian_diagonal);
  system.rhs -= system.gradient;
  EXPECT_TRUE(ReducePass(context, problem.poses, problem.features, lambda, &system).ok());
  return {system.matrix.ToDense(), system.rhs, system.gradient};
}

class ChunkPassesTest : public ::testing::TestWithParam<std::tuple<bool, int>> {};

TEST_P(ChunkPassesTest, ReduceEqualsDenseSchurComplementAndRecoveryEqualsDenseSolve) {
  const auto [range_bearing, chunk_size] = GetParam();
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    testing::RandomProblemOptions options;
    options.seed = seed;
    options.range_bearing = range_bearing;
    options.num_poses = 12;
    options.num_features = 6;
    options.gps_every = seed % 2 == 0 ? 4 : 0;
    testing::RandomProblem random = testing::MakeRandomProblem(options);
    const Problem2d& problem = random.problem;
    partition::ChunkingOptions chunking;
    chunking.max_observations_per_chunk = chunk_size;
    partition::InMemoryChunkSource chunks(problem, chunking);
    const UnknownLayout layout = UnknownLayout::FromProblem(problem);

    testing::DenseReference dense(problem);
    Eigen::MatrixXd h;
    Eigen::VectorXd g;
    dense.Linearize(dense.State(), &h, &g);
    const int nx = dense.num_pose_unknowns();
    const int nm = dense.num_unknowns() - nx;
    const Eigen::MatrixXd hxx = h.topLeftCorner(nx, nx);
    const Eigen::MatrixXd hxm = h.topRightCorner(nx, nm);
    const Eigen::MatrixXd hmm = h.bottomRightCorner(nm, nm);
    const Eigen::MatrixXd schur = hxx - hxm * hmm.ldlt().solve(hxm.transpose());
    const Eigen::VectorXd schur_rhs = -g.head(nx) + hxm * hmm.ldlt().solve(g.tail(nm));

    const Reduced reduced = RunReduce(problem, chunks, layout, 0.0);
    // Central differences of an O(1e4)-scaled residual: relative 1e-6.
    EXPECT_LE((reduced.matrix - schur).norm(), 1e-6 * schur.norm())
        << "seed " << seed << "\nsparse:\n" << reduced.matrix << "\ndense:\n" << schur;
    EXPECT_LE((reduced.rhs - schur_rhs).norm(), 1e-6 * schur_rhs.norm() + 1e-9)
        << "seed " << seed << "\nsparse: " << reduced.rhs.transpose()
        << "\ndense:  " << schur_rhs.transpose();

    // Reduced solve plus recovered features equals the dense full solve.
    const Eigen::VectorXd full = h.ldlt().solve(-g);
    const Eigen::VectorXd dx = reduced.matrix.ldlt().solve(reduced.rhs);
    EXPECT_LE((dx - full.head(nx)).norm(), 1e-5 * full.norm()) << "seed " << seed;
    PassContext context;
    context.chunks = &chunks;
    context.layout = &layout;
    std::vector<Point2> candidate;
    RecoveryResult recovery;
    ASSERT_TRUE(RecoverPass(context, {problem.poses, problem.features, 0.0, dx, problem.poses},
                            &candidate, &recovery)
                    .ok());
    Eigen::VectorXd dm(nm);
    for (int j = 0; j < problem.num_features(); ++j)
      dm.segment<2>(2 * j) = candidate[j] - problem.features[j];
    EXPECT_LE((dm - full.tail(nm)).norm(), 1e-5 * full.norm())
        << "seed " << seed << "\nrecovered: " << dm.transpose()
        << "\ndense:     " << full.tail(nm).transpose();
  }
}

INSTANTIATE_TEST_SUITE_P(KindsAndChunkSizes, ChunkPassesTest,
                         ::testing::Combine(::testing::Bool(), ::testing::Values(1, 7, 100000)));

// (range-bearing, chunk size, kept features + robust kernel)
class FusedPassTest : public ::testing::TestWithParam<std::tuple<bool, int, bool>> {};

TEST_P(FusedPassTest, NextSystemEqualsReducePassAtTheCandidateAndRecoveryIsUnchanged) {
  const auto [range_bearing, chunk_size, keep_and_robust] = GetParam();
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    testing::RandomProblemOptions options;
    options.seed = seed;
    options.range_bearing = range_bearing;
    options.num_poses = 15;
    options.num_features = 8;
    options.gps_every = seed % 2 == 0 ? 4 : 0;
    const Problem2d problem = testing::MakeRandomProblem(options).problem;
    partition::ChunkingOptions chunking;
    chunking.max_observations_per_chunk = chunk_size;
    partition::InMemoryChunkSource chunks(problem, chunking);
    UnknownLayout layout = UnknownLayout::FromProblem(problem);
    PassContext context;
    context.chunks = &chunks;
    context.layout = &layout;
    if (keep_and_robust) {
      std::vector<uint8_t> keep(problem.features.size(), 0);
      for (size_t j = 0; j < keep.size(); j += 3) keep[j] = 1;
      layout.KeepFeatures(keep);
      context.kernel.type = RobustKernel::Type::kCauchy;
      context.kernel.scale = 2.0;
    }

    // A damped step at the initial guess, as the solver takes it.
    const double lambda = 0.3, next_lambda = lambda / 3.0;
    ReducedSystem system = testing::ReducedSystemAt(problem, context, problem.poses);
    ASSERT_TRUE(ReducePass(context, problem.poses, problem.features, lambda, &system).ok());
    Eigen::MatrixXd damped = system.matrix.ToDense();
    damped.diagonal() += lambda * system.hessian_diagonal.cwiseMax(kMinDiagonal);
    const Eigen::VectorXd step = damped.ldlt().solve(system.rhs);
    std::vector<Pose2> candidate_poses = problem.poses;
    for (int p = 0; p < problem.num_poses(); ++p) {
      const int u = layout.unknown_index[p];
      if (u >= 0) candidate_poses[p] = RetractPose(problem.poses[p], step.segment<3>(3 * u));
    }

    std::vector<Point2> recovered;
    RecoveryResult recovery;
    ASSERT_TRUE(RecoverPass(context,
                            {problem.poses, problem.features, lambda, step, candidate_poses},
                            &recovered, &recovery)
                    .ok());
    ReducedSystem next = testing::ReducedSystemAt(problem, context, candidate_poses);
    std::vector<Point2> fused_recovered;
    RecoveryResult fused_recovery;
    Status next_status = Status::Numerical("not set");
    ASSERT_TRUE(RecoverAndReducePass(
                    context, {problem.poses, problem.features, lambda, step, candidate_poses},
                    &fused_recovered, &fused_recovery, {next_lambda, &next, &next_status})
                    .ok());
    ASSERT_TRUE(next_status.ok()) << next_status.ToString();

    // The recovery half is RecoverPass's code: the same numbers.
    EXPECT_EQ(fused_recovery.candidate_chi2, recovery.candidate_chi2) << "seed " << seed;
    EXPECT_EQ(fused_recovery.gradient_dot_step, recovery.gradient_dot_step);
    EXPECT_EQ(fused_recovery.damped_step_norm, recovery.damped_step_norm);
    EXPECT_EQ(fused_recovery.step_squared_norm, recovery.step_squared_norm);
    for (size_t j = 0; j < recovered.size(); ++j)
      EXPECT_EQ((fused_recovered[j] - recovered[j]).norm(), 0.0) << "feature " << j;

    // The reduce half equals a plain ReducePass at the candidate. The design
    // promises bit equality (same kernels, same merge order); the stated
    // tolerance is 1e-12 relative.
    ReducedSystem reference = testing::ReducedSystemAt(problem, context, candidate_poses);
    ASSERT_TRUE(
        ReducePass(context, candidate_poses, recovered, next_lambda, &reference).ok());
    const Eigen::MatrixXd next_dense = next.matrix.ToDense();
    const Eigen::MatrixXd reference_dense = reference.matrix.ToDense();
    EXPECT_LE(testing::RelativeDifference(next_dense, reference_dense), 1e-12)
        << "seed " << seed << "\nfused:\n" << next_dense << "\nReducePass:\n" << reference_dense;
    EXPECT_LE(testing::RelativeDifference(next.rhs, reference.rhs), 1e-12)
        << "fused:      " << next.rhs.transpose() << "\nReducePass: " << reference.rhs.transpose();
    EXPECT_LE(testing::RelativeDifference(next.gradient, reference.gradient), 1e-12);
    EXPECT_LE(testing::RelativeDifference(next.hessian_diagonal, reference.hessian_diagonal), 1e-12);
    EXPECT_NEAR(next.chi2, reference.chi2, 1e-12 * reference.chi2);
    // And it is a different system from the one at the initial guess.
    EXPECT_GT(testing::RelativeDifference(next_dense, system.matrix.ToDense()), 1e-6);
  }
}

INSTANTIATE_TEST_SUITE_P(KindsChunkSizesAndKeptFeatures, FusedPassTest,
                         ::testing::Combine(::testing::Bool(), ::testing::Values(1, 7, 100000),
                                            ::testing::Bool()));

// The fused pass takes the candidate's chi2 from its reduce half and falls
// back to CandidateChi2 when that reduce fails: both must be the recovery's
// own sum, to the bit (FusedPassTest covers the first).
TEST(ChunkPassKernels, CandidateChi2EqualsTheRecoverysSum) {
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    const Problem2d problem =
        testing::MakeRandomProblem({.num_poses = 15, .num_features = 8, .seed = seed}).problem;
    partition::ChunkingOptions chunking;
    chunking.max_observations_per_chunk = 7;
    partition::InMemoryChunkSource chunks(problem, chunking);
    UnknownLayout layout = UnknownLayout::FromProblem(problem);
    std::vector<uint8_t> keep(problem.features.size(), 0);
    keep[1] = 1;
    layout.KeepFeatures(keep);
    std::vector<uint8_t> excluded(problem.features.size(), 0);
    excluded[2] = 1;
    PassContext context;
    context.chunks = &chunks;
    context.layout = &layout;
    context.excluded = &excluded;
    context.kernel.type = RobustKernel::Type::kCauchy;

    // Any step will do: the candidates are what both sums read.
    const Eigen::VectorXd step = Eigen::VectorXd::Constant(3 * layout.num_blocks(), 0.01);
    std::vector<Pose2> candidate_poses = problem.poses;
    for (Pose2& pose : candidate_poses) pose += Pose2(0.02, -0.01, 0.003);
    const BasicRecoveryInput<Space2d> input{problem.poses, problem.features, 0.1, step,
                                            candidate_poses, 1.0};
    const std::vector<Space2d::PoseFrame> frames = PoseFrames<Space2d>(problem.poses);
    ObservationChunk chunk;
    internal::RecoverOutput<Space2d> out;
    for (int64_t c = 0; c < chunks.NumChunks(); ++c) {
      ASSERT_TRUE(chunks.Load(c, &chunk).ok());
      internal::RecoverChunk<Space2d>(context, chunk, input, frames.data(), &out);
      const double with_chi2 = out.sums.candidate_chi2;
      EXPECT_EQ(internal::CandidateChi2<Space2d>(context, chunk, candidate_poses, out.candidates),
                with_chi2)
          << "seed " << seed << " chunk " << c;
      internal::RecoverChunk<Space2d>(context, chunk, input, frames.data(), &out,
                                      /*with_candidate_chi2=*/false);
      EXPECT_EQ(out.sums.candidate_chi2, 0.0);
      if (chunk.num_features() > 0 && !excluded[chunk.features[0]]) {
        EXPECT_GT(with_chi2, 0.0);
      }
    }
  }
}

// Adds feature 99, observed once from `pose` with an information that only
// constrains one direction (its C is rank one, so screening excludes it).
int32_t AddRankOneFeature(int32_t pose, Problem2d* problem) {
  const int32_t f = problem->AddFeature(99, Point2(1.0, 2.0), true);
  Observation o;
  o.pose = pose;
  o.feature = f;
  o.kind = ObservationKind::kPointXY;
  o.z = Eigen::Vector2d(1.0, 1.0);
  o.information << 1.0, 0.0, 0.0, 0.0;
  problem->observations.push_back(o);
  return f;
}

TEST(ChunkPasses, ScreeningExcludesFeatureWithSingularInformation) {
  testing::RandomProblemOptions options;
  options.num_poses = 6;
  options.num_features = 2;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  Problem2d& problem = random.problem;
  // A third feature observed once with an information that only constrains
  // one direction: its C is rank one.
  const int32_t f = AddRankOneFeature(1, &problem);
  problem.AddFeature(100, Point2(0.0, 0.0), true);  // never observed
  partition::InMemoryChunkSource chunks(problem, partition::ChunkingOptions());
  const UnknownLayout layout = UnknownLayout::FromProblem(problem);
  PassContext context;
  context.chunks = &chunks;
  context.layout = &layout;
  ScreeningResult result;
  ASSERT_TRUE(ScreenFeatures(context, problem.poses, problem.features, 64, &result).ok());
  EXPECT_EQ(result.excluded_not_positive_definite, 1);
  EXPECT_EQ(result.unobserved, 1);
  EXPECT_EQ(result.excluded[f], 1);
  EXPECT_EQ(result.excluded[f + 1], 1);
  EXPECT_EQ(result.excluded[0] + result.excluded[1], 0);
}

// The pattern ScreenFeatures collects along (the solve's one setup pass) is
// the pattern of a separate CollectReducedPattern pass with the screening's
// partition, with eliminated, kept and excluded features and any chunk size.
TEST(ChunkPasses, ScreenedPatternEqualsCollectedPattern) {
  for (const int chunk_size : {1, 5, 100000}) {
    for (uint32_t seed = 1; seed <= 3; ++seed) {
      testing::RandomProblemOptions options;
      options.seed = seed;
      options.num_poses = 20;
      options.num_features = 15;
      testing::RandomProblem random = testing::MakeRandomProblem(options);
      Problem2d& problem = random.problem;
      // A feature whose information is rank one: excluded by the screening.
      const int32_t f = AddRankOneFeature(3, &problem);
      partition::ChunkingOptions chunking;
      chunking.max_observations_per_chunk = chunk_size;
      partition::InMemoryChunkSource chunks(problem, chunking);

      UnknownLayout layout = UnknownLayout::FromProblem(problem);
      PassContext context;
      context.chunks = &chunks;
      context.layout = &layout;
      ScreeningResult screening;
      ScreenedPattern screened;
      // Features with more observations than the median are kept features.
      std::vector<int64_t> counts(problem.features.size(), 0);
      for (const Observation& observation : problem.observations) ++counts[observation.feature];
      std::vector<int64_t> sorted = counts;
      std::sort(sorted.begin(), sorted.end());
      const int64_t median = sorted[sorted.size() / 2];
      ASSERT_TRUE(ScreenFeatures(context, problem.poses, problem.features, median, &screening,
                                 &screened)
                      .ok());
      ASSERT_EQ(screening.excluded[f], 1);
      ASSERT_GT(screening.kept_count, 0);
      ASSERT_LT(screening.kept_count, problem.num_features() - 1);
      layout.KeepFeatures(screening.kept);
      context.excluded = &screening.excluded;

      std::vector<std::pair<int, int>> from_screen;
      AppendScreenedPattern(layout, &screened, &from_screen);
      std::vector<std::pair<int, int>> collected;
      ASSERT_TRUE(CollectReducedPattern(context, &collected).ok());
      const BlockSparseMatrix a =
          BlockSparseMatrix::FromPattern(3, layout.num_blocks(), std::move(from_screen));
      const BlockSparseMatrix b =
          BlockSparseMatrix::FromPattern(3, layout.num_blocks(), std::move(collected));
      EXPECT_EQ(a.row_start(), b.row_start());
      EXPECT_EQ(a.block_cols(), b.block_cols());
      EXPECT_GT(a.num_nonzero_blocks(), layout.num_blocks());  // not only the diagonal
    }
  }
}

// PosePairSet emits each unordered pair once, in order of first insertion,
// also across growth of its table, and is empty again after Clear.
TEST(PosePairSet, EmitsEachUnorderedPairOnce) {
  internal::PosePairSet set;
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> pose(0, 200);
  for (int round = 0; round < 3; ++round) {
    set.Clear();
    std::vector<std::pair<int, int>> emitted;
    std::vector<std::pair<int, int>> reference;
    for (int n = 0; n < 5000; ++n) {
      const int a = pose(rng);
      const int b = pose(rng);
      set.Insert(a, b, &emitted);
      const std::pair<int, int> key(std::min(a, b), std::max(a, b));
      if (std::find(reference.begin(), reference.end(), key) == reference.end())
        reference.push_back(key);
    }
    EXPECT_EQ(emitted, reference);
    EXPECT_GT(emitted.size(), 1024u);  // the table grew past its first capacity
  }
}

}  // namespace
}  // namespace graphslam::core
