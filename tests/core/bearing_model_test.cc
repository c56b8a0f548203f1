// The bearing-only model: residual, Jacobians against central differences,
// first-sight placement, its registry entry (chunk record, native log record),
// and small planar problems solved to known optima: noise-free data reaches
// chi2 ~ 0 at the true map from the Table 1 initialization, noisy data the
// dense Gauss-Newton optimum.
#include "core/bearing_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "core/observation_models.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/chunk_format.h"
#include "storage/native_log_reader.h"
#include "tests/testing/dense_reference.h"
#include "tests/testing/numeric_diff.h"
#include "tests/testing/planar_draws.h"
#include "tests/testing/random_problem.h"
#include "tests/testing/tight_solver_options.h"

namespace graphslam::core {
namespace {

using testing::NumericJacobian;
constexpr double kPi = std::numbers::pi;
constexpr unsigned kSeed = 20261127;

double MaxAbs(const Eigen::MatrixXd& m) { return m.cwiseAbs().maxCoeff(); }

TEST(BearingModel, KnownBearingAndZeroPadding) {
  // Robot at (1, 1) facing +y; feature at (4, 5): world angle atan2(4, 3).
  const Pose2 pose(1.0, 1.0, kPi / 2.0);
  Eigen::Vector2d residual;
  ASSERT_TRUE(BearingModel::Evaluate(pose, Point2(4.0, 5.0), Eigen::Vector2d(0.1, 0.0), &residual,
                                     nullptr, nullptr));
  EXPECT_NEAR(residual(0), std::atan2(4.0, 3.0) - kPi / 2.0 - 0.1, 1e-15);
  EXPECT_EQ(residual(1), 0.0);
  // The residual is wrapped: a feature behind the robot measured across +-pi.
  ASSERT_TRUE(BearingModel::Evaluate(Pose2::Zero(), Point2(-2.0 * std::cos(0.01), -2.0 * std::sin(0.01)),
                                     Eigen::Vector2d(kPi - 0.01, 0.0), &residual, nullptr, nullptr));
  EXPECT_NEAR(residual(0), 0.02, 1e-12);
}

TEST(BearingModel, FeatureOnTheRobotIsDegenerate) {
  const Pose2 pose(2.0, -1.0, 0.3);
  Eigen::Vector2d residual(7.0, 7.0);
  EXPECT_FALSE(BearingModel::Evaluate(pose, pose.head<2>(), Eigen::Vector2d::Zero(), &residual,
                                      nullptr, nullptr));
  EXPECT_EQ(residual, Eigen::Vector2d(7.0, 7.0));  // untouched
}

TEST(BearingModel, JacobiansMatchCentralDifferencesIncludingAcrossPi) {
  std::mt19937 rng(kSeed);
  std::uniform_real_distribution<double> small(-0.05, 0.05);
  for (int i = 0; i < 1000; ++i) {
    const auto [pose, feature, world_angle] = testing::DrawAcrossPi(i, rng);
    const Eigen::Vector2d z(WrapAngle(world_angle - pose.z() + small(rng)), 0.0);
    SCOPED_TRACE(::testing::Message() << "bearing draw " << i << ": " << pose.transpose() << " -> "
                                      << feature.transpose());
    Eigen::Matrix<double, 2, 3> jacobian_pose;
    Eigen::Matrix2d jacobian_feature;
    ASSERT_TRUE(
        BearingModel::Evaluate(pose, feature, z, nullptr, &jacobian_pose, &jacobian_feature));
    auto residual_at = [&](const Pose2& x, const Point2& m) {
      Eigen::Vector2d e;
      EXPECT_TRUE(BearingModel::Evaluate(x, m, z, &e, nullptr, nullptr));
      return Eigen::VectorXd(e);
    };
    const Eigen::MatrixXd numeric_pose = NumericJacobian(
        [&](const Eigen::VectorXd& x) { return residual_at(Pose2(x), feature); }, pose);
    const Eigen::MatrixXd numeric_feature = NumericJacobian(
        [&](const Eigen::VectorXd& m) { return residual_at(pose, Point2(m)); }, feature);
    const double scale = 1.0 + MaxAbs(jacobian_pose);
    EXPECT_LE(MaxAbs(Eigen::MatrixXd(jacobian_pose) - numeric_pose), 1e-6 * scale);
    EXPECT_LE(MaxAbs(Eigen::MatrixXd(jacobian_feature) - numeric_feature), 1e-6 * scale);
    EXPECT_EQ(jacobian_pose.row(1).norm(), 0.0);
    EXPECT_EQ(jacobian_feature.row(1).norm(), 0.0);
  }
}

TEST(BearingModel, FirstSightLiesOnTheRayAtTheDefaultRange) {
  const Pose2 pose(3.0, -2.0, 2.5);
  const Eigen::Vector2d z(-0.7, 0.0);
  const Point2 placed = InvertObservation(ObservationKind::kBearing, pose, z);
  EXPECT_NEAR((placed - pose.head<2>()).norm(), BearingModel::kFirstSightRange, 1e-12);
  Eigen::Vector2d residual;
  ASSERT_TRUE(BearingModel::Evaluate(pose, placed, z, &residual, nullptr, nullptr));
  EXPECT_NEAR(residual.norm(), 0.0, 1e-12);
}

TEST(BearingModel, RegistryDispatchesKindTwo) {
  EXPECT_EQ(static_cast<int>(ObservationKind::kBearing), 2);
  EXPECT_TRUE(IsObservationKind(2));
  EXPECT_STREQ(ObservationKindName(ObservationKind::kBearing), "bearing");
  EXPECT_EQ(MeasurementDim(ObservationKind::kBearing), 1);
  ObservationKind kind = ObservationKind::kRangeBearing;
  ASSERT_TRUE(ObservationKindOfNativeLogTag("B", &kind));
  EXPECT_EQ(kind, ObservationKind::kBearing);
  const Pose2 pose(0.5, 0.5, 0.2);
  const Point2 feature(3.0, 4.0);
  const Eigen::Vector2d z(0.4, 0.0);
  Eigen::Vector2d direct, dispatched;
  ASSERT_TRUE(BearingModel::Evaluate(pose, feature, z, &direct, nullptr, nullptr));
  ASSERT_TRUE(EvaluateObservation(ObservationKind::kBearing, pose, feature, z, &dispatched, nullptr,
                                  nullptr));
  EXPECT_EQ(direct, dispatched);
}

TEST(BearingModel, ChunkRecordRoundTripsAndValidates) {
  Observation o;
  o.pose = 4;
  o.feature = 9;
  o.kind = ObservationKind::kBearing;
  o.z = Eigen::Vector2d(-1.25, 0.0);
  o.information = Eigen::Vector2d(400.0, 1.0).asDiagonal();
  o.line = 17;
  std::string bytes;
  storage::chunk_format::PutObservation(&bytes, o);
  ASSERT_EQ(bytes.size(), storage::chunk_format::kObservationSize);
  Observation back;
  storage::chunk_format::DecodeObservation(bytes.data(), &back);
  EXPECT_EQ(back.kind, ObservationKind::kBearing);
  EXPECT_EQ(back.z, o.z);
  EXPECT_EQ(back.information, o.information);
  EXPECT_TRUE(storage::chunk_format::IsValidObservation(back, 9));
  EXPECT_EQ(storage::chunk_format::DescribeInvalidObservation(back, 9), "");
}

TEST(BearingModel, NativeLogRecordReadsAndWritesBack) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "bearing_log";
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "in.log").string();
  std::ofstream(path) << "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\nB 0 7 0.25 400\n";
  StatusOr<Problem2d> problem = storage::ReadNativeLog(path);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  ASSERT_EQ(problem->observations.size(), 1u);
  const Observation& o = problem->observations[0];
  EXPECT_EQ(o.kind, ObservationKind::kBearing);
  EXPECT_EQ(o.z, Eigen::Vector2d(0.25, 0.0));
  EXPECT_EQ(o.information, Eigen::Matrix2d(Eigen::Vector2d(400.0, 1.0).asDiagonal()));
  const std::string copy = (dir / "copy.log").string();
  ASSERT_TRUE(storage::WriteNativeLog(*problem, copy).ok());
  StatusOr<Problem2d> again = storage::ReadNativeLog(copy);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  ASSERT_EQ(again->observations.size(), 1u);
  EXPECT_EQ(again->observations[0].z, o.z);
  EXPECT_EQ(again->observations[0].information, o.information);
  // A bearing record has one measured value and one information entry.
  std::ofstream(path) << "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\nB 0 7 0.25 1 0 400\n";
  EXPECT_FALSE(storage::ReadNativeLog(path).ok());
  std::ofstream(path) << "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\nB 0 7 0.25 0\n";
  const StatusOr<Problem2d> zero = storage::ReadNativeLog(path);
  ASSERT_FALSE(zero.ok());
  EXPECT_NE(zero.status().message().find("B information 0 is not positive"), std::string::npos)
      << zero.status().message();
  std::filesystem::remove_all(dir);
}

// The random loop world of the solver tests with every range-bearing
// observation reduced to its bearing: z = (phi, 0), information diag(w, 1).
testing::RandomProblem BearingWorld(uint32_t seed) {
  testing::RandomProblemOptions options;
  options.num_poses = 30;
  options.num_features = 10;
  options.range_bearing = true;
  options.seed = seed;
  testing::RandomProblem random = testing::MakeRandomProblem(options);
  for (Observation& o : random.problem.observations) {
    o.kind = ObservationKind::kBearing;
    o.z = Eigen::Vector2d(o.z(1), 0.0);
    o.information = Eigen::Vector2d(o.information(1, 1), 1.0).asDiagonal();
  }
  return random;
}

SolverSummary Solve(Problem2d* problem) {
  partition::InMemoryChunkSource chunks(*problem, partition::ChunkingOptions());
  SolverSummary summary;
  const Status status =
      SolveGraphSlam(testing::TightCholmodSolverOptions(), chunks, problem, &summary);
  EXPECT_TRUE(status.ok()) << status.ToString();
  return summary;
}

TEST(BearingModel, NoiseFreeBearingsReachTheTrueMapFromFirstSight) {
  testing::RandomProblem random = BearingWorld(3);
  Problem2d& problem = random.problem;
  // Exact measurements: odometry between true poses, bearings to true features.
  for (RelativePoseConstraint& c : problem.relative_poses)
    c.z = Between(random.true_poses[c.from], random.true_poses[c.to]);
  for (Observation& o : problem.observations) {
    const Eigen::Vector2d delta = random.true_features[o.feature] - random.true_poses[o.pose].head<2>();
    o.z(0) = WrapAngle(std::atan2(delta.y(), delta.x()) - random.true_poses[o.pose].z());
  }
  // Table 1: poses chained from odometry (exact), features at first sight.
  problem.poses[0] = random.true_poses[0];
  for (int p = 1; p < problem.num_poses(); ++p) problem.pose_initialized[p] = 0;
  for (int j = 0; j < problem.num_features(); ++j) problem.feature_initialized[j] = 0;
  ASSERT_TRUE(InitializeProblem(&problem).ok());
  ASSERT_GT((problem.features[0] - random.true_features[0]).norm(), 0.5);  // a real start

  const SolverSummary summary = Solve(&problem);
  EXPECT_TRUE(summary.converged) << summary.termination;
  EXPECT_GT(summary.initial_chi2, 1.0);
  EXPECT_LT(summary.final_chi2, 1e-12);
  for (int j = 0; j < problem.num_features(); ++j)
    EXPECT_LT((problem.features[j] - random.true_features[j]).norm(), 1e-6) << "feature " << j;
  for (int p = 0; p < problem.num_poses(); ++p)
    EXPECT_LT((problem.poses[p] - random.true_poses[p]).norm(), 1e-6) << "pose " << p;
}

TEST(BearingModel, NoisyBearingsReachTheDenseGaussNewtonOptimum) {
  for (uint32_t seed = 1; seed <= 3; ++seed) {
    testing::RandomProblem random = BearingWorld(seed);
    const Problem2d start = random.problem;
    testing::DenseReference dense(start);
    const double dense_optimum = dense.Chi2(dense.SolveGaussNewton(50));
    const SolverSummary summary = Solve(&random.problem);
    EXPECT_TRUE(summary.converged) << summary.termination;
    EXPECT_NEAR(summary.final_chi2, dense_optimum, 1e-6 * dense_optimum) << "seed " << seed;
    EXPECT_LT(summary.final_chi2, summary.initial_chi2);
    // The reported chi2 is the chi2 of the returned state.
    testing::DenseReference after(random.problem);
    EXPECT_NEAR(after.Chi2(after.State()), summary.final_chi2, 1e-9 * summary.final_chi2);
  }
}

}  // namespace
}  // namespace graphslam::core
