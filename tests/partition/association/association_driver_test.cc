// Tests of the data association driver (partition/association/association_driver.h):
// the correspondence test against a dense inverse of the full information
// matrix, two copies of one landmark merging back to the known-correspondence
// optimum, a wrong forced merge being undone, and an id-less simulated problem
// associated with bounded precision and recall.
#include "partition/association/association_driver.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

#include "core/initialization.h"
#include "core/unidentified_features.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "tests/testing/dense_reference.h"
#include "tests/testing/random_problem.h"
#include "tests/testing/tight_solver_options.h"

namespace graphslam::partition {
namespace {

core::SolverOptions TightSolverOptions() { return testing::TightCholmodSolverOptions(); }

double SolveKnown(core::Problem2d* problem) {
  InMemoryChunkSource chunks(*problem, ChunkingOptions());
  core::SolverSummary summary;
  EXPECT_TRUE(core::SolveGraphSlam(TightSolverOptions(), chunks, problem, &summary).ok());
  return summary.final_chi2;
}

// pi_{j=k} from the dense inverse of the full (poses + features) Gauss-Newton
// information at the current state: Sigma = H^{-1}, D = [I -I].
double DenseCorrespondence(const core::Problem2d& problem, int j, int k) {
  testing::DenseReference dense(problem);
  Eigen::MatrixXd h;
  Eigen::VectorXd g;
  dense.Linearize(dense.State(), &h, &g);
  const Eigen::MatrixXd sigma = h.inverse();
  const int base = dense.num_pose_unknowns();
  Eigen::MatrixXd d = Eigen::MatrixXd::Zero(2, sigma.rows());
  d.block(0, base + 2 * j, 2, 2).setIdentity();
  d.block(0, base + 2 * k, 2, 2) = -Eigen::Matrix2d::Identity();
  const Eigen::Matrix2d cov = d * sigma * d.transpose();
  const Eigen::Vector2d mu = problem.features[j] - problem.features[k];
  return std::exp(-0.5 * mu.dot(cov.inverse() * mu)) /
         (2.0 * std::numbers::pi * std::sqrt(cov.determinant()));
}

void ExpectMatchesDense(bool range_bearing, int64_t max_eliminated) {
  testing::RandomProblemOptions options;
  options.num_poses = 14;
  options.num_features = 6;
  options.range_bearing = range_bearing;
  options.seed = 5;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  core::Problem2d& problem = random.problem;
  ASSERT_TRUE(core::InitializeProblem(&problem).ok());
  SolveKnown(&problem);
  core::SolverOptions solver = TightSolverOptions();
  solver.max_eliminated_observations = max_eliminated;
  std::vector<CorrespondenceQuery> queries;
  for (int j = 0; j < problem.num_features(); ++j)
    for (int k = j + 1; k < problem.num_features(); ++k) {
      CorrespondenceQuery query;
      query.j = j;
      query.k = k;
      queries.push_back(query);
    }
  ASSERT_TRUE(TestCorrespondences(solver, problem, 3, &queries).ok());
  int tested = 0;
  for (const CorrespondenceQuery& q : queries) {
    ASSERT_TRUE(q.result.valid) << q.j << " " << q.k;
    const double expected = DenseCorrespondence(problem, q.j, q.k);
    // Central differences make the dense H accurate to ~1e-8 relative.
    EXPECT_NEAR(q.result.probability, expected, 1e-6 * expected + 1e-300)
        << "pair " << q.j << " " << q.k;
    ++tested;
  }
  EXPECT_EQ(tested, 15);
}

TEST(AssociationDriver, CorrespondenceMatchesDenseInversePointObservations) {
  ExpectMatchesDense(false, 64);
}
TEST(AssociationDriver, CorrespondenceMatchesDenseInverseRangeBearing) {
  ExpectMatchesDense(true, 64);
}
TEST(AssociationDriver, CorrespondenceMatchesDenseInverseWithKeptFeatures) {
  ExpectMatchesDense(true, 3);  // features with > 3 observations stay unknowns
}

TEST(AssociationDriver, TwoCopiesOfOneLandmarkMergeBack) {
  testing::RandomProblem random = testing::MakeSmallPointWorld(11);
  core::Problem2d known = random.problem;
  ASSERT_TRUE(core::InitializeProblem(&known).ok());
  const double known_chi2 = SolveKnown(&known);

  // Landmark 0's observations alternate between it and a copy.
  core::Problem2d split = random.problem;
  const int32_t copy = split.AddFeature(5000, split.features[0], true);
  int seen = 0;
  for (core::Observation& o : split.observations)
    if (o.feature == 0 && (seen++ % 2) == 1) o.feature = copy;
  ASSERT_GE(seen, 4);
  ASSERT_TRUE(core::InitializeProblem(&split).ok());
  AssociationOptions options;
  options.search_radius = 2.0;
  AssociationSummary summary;
  ASSERT_TRUE(AssociateAndSolve(options, TightSolverOptions(), &split, &summary).ok());
  EXPECT_EQ(summary.merges, 1);
  EXPECT_EQ(summary.undone, 0);
  EXPECT_EQ(split.num_features(), known.num_features());
  EXPECT_NEAR(summary.final_solve.final_chi2, known_chi2, 1e-9 * known_chi2);
  // Every observation of landmark 0 (either copy) now points to one feature.
  int32_t merged = -1;
  for (size_t i = 0; i < split.observations.size(); ++i) {
    if (random.problem.observations[i].feature != 0) continue;
    if (merged < 0) merged = split.observations[i].feature;
    EXPECT_EQ(split.observations[i].feature, merged);
  }
  EXPECT_EQ(split.feature_ids[merged], 1000);  // the smallest input id of the cluster
}

TEST(AssociationDriver, WrongForcedMergeIsUndone) {
  testing::RandomProblem random = testing::MakeSmallPointWorld(12);
  core::Problem2d known = random.problem;
  ASSERT_TRUE(core::InitializeProblem(&known).ok());
  const double known_chi2 = SolveKnown(&known);
  // The two landmarks farthest apart.
  int a = 0, b = 1;
  for (int j = 0; j < 10; ++j)
    for (int k = j + 1; k < 10; ++k)
      if ((random.true_features[j] - random.true_features[k]).norm() >
          (random.true_features[a] - random.true_features[b]).norm()) {
        a = j;
        b = k;
      }
  for (bool refit : {false, true}) {
  SCOPED_TRACE(refit ? "refit between undos" : "full re-solve between undos");
  core::Problem2d problem = random.problem;
  ASSERT_TRUE(core::InitializeProblem(&problem).ok());
  AssociationOptions options;
  options.search_radius = 0.5;
  options.forced_merges = {{a, b}};
  options.refit_between_undos = refit;
  AssociationSummary summary;
  ASSERT_TRUE(AssociateAndSolve(options, TightSolverOptions(), &problem, &summary).ok());
  ASSERT_FALSE(summary.merge_log.empty());
  EXPECT_TRUE(summary.merge_log.front().forced);
  EXPECT_TRUE(summary.merge_log.front().undone);
  EXPECT_EQ(summary.undone, 1);
  EXPECT_EQ(problem.num_features(), 10);
  EXPECT_NEAR(summary.final_solve.final_chi2, known_chi2, 1e-6 * known_chi2);
  int32_t fa = -1, fb = -1;
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    if (random.problem.observations[i].feature == a) fa = problem.observations[i].feature;
    if (random.problem.observations[i].feature == b) fb = problem.observations[i].feature;
  }
  EXPECT_NE(fa, fb);
  }
}

// Two landmarks 1 m apart, A seen from poses 0..9 and B from 10..19 (never
// from a common pose), point observations with sigma 0.1 m. A forced merge of
// A and B is wrong and undone; with an acceptance so loose that the test
// would accept the pair again (chi ~ 0, no Mahalanobis gate), only the memory
// of undone pairs keeps it from being merged and undone every round until
// max_rounds.
TEST(AssociationDriver, WrongMergeIsUndoneAndStaysUndone) {
  core::Problem2d base;
  std::mt19937 rng(21);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int p = 0; p < 20; ++p) base.AddPose(p, core::Pose2(p, 0.0, 0.0), true, 0, p);
  base.pose_fixed[0] = 1;
  for (int p = 0; p + 1 < 20; ++p) {
    core::RelativePoseConstraint c;
    c.from = p;
    c.to = p + 1;
    c.z = core::Pose2(1.0, 0.0, 0.0) + core::Pose2(0.01 * noise(rng), 0.01 * noise(rng), 0.001 * noise(rng));
    c.information = Eigen::Vector3d(1e4, 1e4, 1e6).asDiagonal();
    base.relative_poses.push_back(c);
  }
  const core::Point2 landmark[2] = {core::Point2(9.0, 2.0), core::Point2(10.0, 2.0)};
  const int32_t a = base.AddFeature(1000, landmark[0], true);
  const int32_t b = base.AddFeature(1001, landmark[1], true);
  for (int p = 0; p < 20; ++p) {
    core::Observation o;
    o.pose = p;
    o.feature = p < 10 ? a : b;
    o.kind = core::ObservationKind::kPointXY;
    o.z = landmark[p < 10 ? 0 : 1] - core::Point2(p, 0.0) + core::Point2(noise(rng), noise(rng));
    o.information = 100.0 * Eigen::Matrix2d::Identity();
    base.observations.push_back(o);
  }
  for (const auto& [refit, full_solve_undos] :
       {std::pair{false, 1}, std::pair{true, 1}, std::pair{false, 2}}) {
    SCOPED_TRACE(std::string(refit ? "refit between undos" : "full re-solve between undos") +
                 ", full_solve_undos " + std::to_string(full_solve_undos));
    core::Problem2d problem = base;
    AssociationOptions options;
    options.chi = 1e-300;
    options.max_mahalanobis_squared = 1e12;
    options.forced_merges = {{a, b}};
    options.refit_between_undos = refit;
    options.full_solve_undos = full_solve_undos;
    options.max_rounds = 6;
    AssociationSummary summary;
    ASSERT_TRUE(AssociateAndSolve(options, TightSolverOptions(), &problem, &summary).ok());
    // Merged once (the forced merge) or, with a second chance, twice; every
    // time undone, and never merged again.
    ASSERT_EQ(summary.merge_log.size(), static_cast<size_t>(full_solve_undos));
    EXPECT_TRUE(summary.merge_log.front().forced);
    for (const MergeRecord& record : summary.merge_log) EXPECT_TRUE(record.undone);
    EXPECT_EQ(summary.undone, full_solve_undos);
    EXPECT_EQ(summary.merges, 0);
    EXPECT_TRUE(summary.converged) << "stopped by max_rounds: the pair kept coming back";
    EXPECT_EQ(problem.num_features(), 2);
    EXPECT_NE(problem.observations[0].feature, problem.observations[19].feature);
    for (int p = 0; p < 20; ++p)
      EXPECT_EQ(problem.observations[p].feature, problem.observations[p < 10 ? 0 : 19].feature);
  }
}

TEST(AssociationDriver, IdLessSimulationIsAssociatedAccurately) {
  testing::RandomProblem random = testing::MakeSmallPointWorld(13);
  // Forget the ids: one feature per observation.
  core::Problem2d problem = random.problem;
  std::vector<int64_t> key;
  problem.features.clear();
  problem.feature_ids.clear();
  problem.feature_initialized.clear();
  for (core::Observation& o : problem.observations) {
    key.push_back(o.feature);
    o.feature = problem.AddFeature(core::kNoFeatureId, core::Point2::Zero(), false);
  }
  ASSERT_TRUE(core::InitializeProblem(&problem).ok());
  const core::Problem2d initialized = problem;
  // Default; mutual-best-match first rounds; re-fits between undo passes.
  for (const auto& [mutual, refit] : {std::pair{0, false}, std::pair{2, false}, std::pair{0, true}}) {
  SCOPED_TRACE("mutual_best_rounds " + std::to_string(mutual) + " refit " + std::to_string(refit));
  problem = initialized;
  AssociationOptions options;
  options.search_radius = 2.0;
  options.mutual_best_rounds = mutual;
  options.refit_between_undos = refit;
  AssociationSummary summary;
  ASSERT_TRUE(AssociateAndSolve(options, TightSolverOptions(), &problem, &summary).ok());
  const PairwiseScore score =
      ScorePairwise(InputObservationLabels(problem, summary, key.size()), key);
  EXPECT_GE(score.precision(), 0.99) << score.true_positive << "/" << score.predicted;
  EXPECT_GE(score.recall(), 0.95) << score.true_positive << "/" << score.actual;
  // Fresh ids above the pose ids for id-less inputs.
  for (int64_t id : problem.feature_ids) EXPECT_GE(id, problem.num_poses());
  }
}

TEST(AssociationDriver, ScorePairwiseCountsPairs) {
  // Assigned {0,0,1,1}, key {0,0,0,1}: predicted 2 pairs, actual 3, both share (0,1).
  const PairwiseScore score = ScorePairwise({0, 0, 1, 1}, {0, 0, 0, 1});
  EXPECT_EQ(score.predicted, 2);
  EXPECT_EQ(score.actual, 3);
  EXPECT_EQ(score.true_positive, 1);
}

TEST(AssociationDriver, OptionsAreValidated) {
  AssociationOptions options;
  options.search_radius = 0.0;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  options = AssociationOptions();
  options.chi = -1.0;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  for (const double z : {std::numeric_limits<double>::quiet_NaN(),
                         std::numeric_limits<double>::infinity()}) {
    options = AssociationOptions();
    options.undo_z = z;
    EXPECT_TRUE(options.Validate().IsInvalidArgument()) << z;
  }
  EXPECT_TRUE(AssociationOptions().Validate().ok());
}

}  // namespace
}  // namespace graphslam::partition
