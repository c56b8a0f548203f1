#include "core/initialization.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

#include "core/range_bearing_model.h"
#include "core/se2.h"
#include "core/velocity_motion_model.h"

namespace graphslam::core {
namespace {

using ::testing::HasSubstr;
using ::testing::StartsWith;
constexpr double kPi = std::numbers::pi;

void ExpectPoseNear(const Pose2& actual, const Pose2& expected, double tolerance) {
  Eigen::Vector3d error = actual - expected;
  error.z() = WrapAngle(error.z());
  EXPECT_LE(error.cwiseAbs().maxCoeff(), tolerance)
      << "actual " << actual.transpose() << "\nexpected " << expected.transpose();
}

// A lawnmower-like trajectory starting at the origin: straight runs and turns,
// crossing theta = +-pi.
std::vector<Pose2> KnownTrajectory(int count) {
  std::vector<Pose2> truth{Pose2::Zero()};
  for (int i = 1; i < count; ++i) {
    const VelocityControl control{.v = 1.0, .omega = (i / 5) % 2 == 0 ? 0.0 : 0.6, .dt = 1.0};
    truth.push_back(PredictVelocityMotion(truth.back(), control));
  }
  return truth;
}

// A problem with `count` uninitialized poses, ids 100 + i, one per line i + 1.
Problem2d EmptyPoses(int count) {
  Problem2d problem;
  problem.source = "intel.g2o";
  for (int i = 0; i < count; ++i) problem.AddPose(100 + i, Pose2::Zero(), false, i + 1);
  return problem;
}

RelativePoseConstraint Edge(const std::vector<Pose2>& truth, int from, int to, int line = 0) {
  RelativePoseConstraint edge;
  edge.from = from;
  edge.to = to;
  edge.z = Between(truth[from], truth[to]);
  edge.line = line;
  return edge;
}

TEST(Initialization, EdgesOnlyChainReproducesKnownTrajectory) {
  const std::vector<Pose2> truth = KnownTrajectory(30);
  Problem2d problem = EmptyPoses(30);
  for (int i = 0; i + 1 < 30; ++i) {
    // Every third edge is stored backwards, to exercise x_from = x_to (+) z^-1.
    problem.relative_poses.push_back(i % 3 == 0 ? Edge(truth, i + 1, i) : Edge(truth, i, i + 1));
  }
  problem.relative_poses.push_back(Edge(truth, 25, 3));  // loop closure, consistent
  ASSERT_TRUE(InitializeProblem(&problem).ok());
  for (int i = 0; i < 30; ++i) {
    SCOPED_TRACE(::testing::Message() << "pose " << i);
    EXPECT_EQ(problem.pose_initialized[i], 1);
    ExpectPoseNear(problem.poses[i], truth[i], 1e-9);
  }
}

TEST(Initialization, ChainsFromInitializedPosesAndKeepsTheirGuesses) {
  const std::vector<Pose2> truth = KnownTrajectory(10);
  Problem2d problem = EmptyPoses(10);
  for (int i = 0; i + 1 < 10; ++i) problem.relative_poses.push_back(Edge(truth, i, i + 1));
  // Only pose 6 has a guess from the input, 1 m off the truth in x. It is kept
  // as is, and every other pose is chained from it (0..5 backwards), so the
  // whole trajectory comes out shifted by the same (1, 0, 0).
  problem.poses[6] = truth[6] + Pose2(1.0, 0.0, 0.0);
  problem.pose_initialized[6] = 1;
  ASSERT_TRUE(InitializeProblem(&problem).ok());
  ExpectPoseNear(problem.poses[6], truth[6] + Pose2(1.0, 0.0, 0.0), 0.0);
  for (int i = 0; i < 10; ++i) {
    SCOPED_TRACE(::testing::Message() << "pose " << i);
    ExpectPoseNear(problem.poses[i], truth[i] + Pose2(1.0, 0.0, 0.0), 1e-9);
  }
}

TEST(Initialization, VelocityMotionsChainForwardAndBackward) {
  std::vector<VelocityControl> controls;
  std::vector<Pose2> truth{Pose2(2.0, -1.0, 3.0)};
  for (int i = 0; i < 12; ++i) {
    controls.push_back({.v = 0.5 + 0.1 * i, .omega = i % 3 == 0 ? 0.0 : -0.4 + 0.1 * i, .dt = 0.8});
    truth.push_back(PredictVelocityMotion(truth.back(), controls.back()));
  }
  for (int seed : {0, 12}) {  // the one initialized pose: first, then last
    SCOPED_TRACE(::testing::Message() << "initialized pose " << seed);
    Problem2d problem = EmptyPoses(13);
    problem.poses[seed] = truth[seed];
    problem.pose_initialized[seed] = 1;
    for (int i = 0; i < 12; ++i) {
      VelocityMotionConstraint motion;
      motion.from = i;
      motion.to = i + 1;
      motion.control = controls[i];
      problem.motions.push_back(motion);
    }
    ASSERT_TRUE(InitializeProblem(&problem).ok());
    for (int i = 0; i < 13; ++i) ExpectPoseNear(problem.poses[i], truth[i], 1e-9);
  }
}

TEST(Initialization, NoInitializedPoseStartsFromPoseZeroAtOrigin) {
  // Table 1 l.2: mu_0 = 0 even when the edges describe a trajectory elsewhere.
  std::vector<Pose2> truth{Pose2(5.0, 5.0, 1.0), Pose2(6.0, 5.0, 1.5)};
  Problem2d problem = EmptyPoses(2);
  problem.relative_poses.push_back(Edge(truth, 0, 1));
  ASSERT_TRUE(InitializeProblem(&problem).ok());
  ExpectPoseNear(problem.poses[0], Pose2::Zero(), 0.0);
  ExpectPoseNear(problem.poses[1], Between(truth[0], truth[1]), 1e-12);
}

TEST(Initialization, FeaturesFromFirstSight) {
  const std::vector<Pose2> truth = KnownTrajectory(8);
  Problem2d problem = EmptyPoses(8);
  for (int i = 0; i + 1 < 8; ++i) problem.relative_poses.push_back(Edge(truth, i, i + 1));
  const Point2 landmark(2.0, 3.0), point(-1.0, 4.0), known(7.0, 7.0);
  const int32_t range_bearing_feature = problem.AddFeature(500, Point2::Zero(), false);
  const int32_t point_feature = problem.AddFeature(501, Point2::Zero(), false);
  const int32_t known_feature = problem.AddFeature(502, known, true);
  const int32_t unseen_feature = problem.AddFeature(503, Point2(-9.0, -9.0), false);
  auto observe = [&](int32_t pose, int32_t feature, ObservationKind kind, const Point2& where,
                     const Eigen::Vector2d& bias) {
    Observation observation;
    observation.pose = pose;
    observation.feature = feature;
    observation.kind = kind;
    const Eigen::Vector2d local =
        Rotation2(truth[pose].z()).transpose() * (where - truth[pose].head<2>());
    observation.z = (kind == ObservationKind::kRangeBearing
                         ? Eigen::Vector2d(local.norm(), std::atan2(local.y(), local.x()))
                         : local) +
                    bias;
    problem.observations.push_back(observation);
  };
  // The first observation (index order, not pose order) is the exact one;
  // the later ones are biased and must be ignored.
  observe(5, range_bearing_feature, ObservationKind::kRangeBearing, landmark,
          Eigen::Vector2d::Zero());
  observe(2, range_bearing_feature, ObservationKind::kRangeBearing, landmark,
          Eigen::Vector2d(1.0, 0.3));
  observe(1, point_feature, ObservationKind::kPointXY, point, Eigen::Vector2d::Zero());
  observe(6, point_feature, ObservationKind::kPointXY, point, Eigen::Vector2d(-2.0, 0.5));
  observe(3, known_feature, ObservationKind::kPointXY, known, Eigen::Vector2d(3.0, 3.0));
  ASSERT_TRUE(InitializeProblem(&problem).ok());
  EXPECT_LE((problem.features[range_bearing_feature] - landmark).norm(), 1e-9)
      << problem.features[range_bearing_feature].transpose();
  EXPECT_LE((problem.features[point_feature] - point).norm(), 1e-9)
      << problem.features[point_feature].transpose();
  EXPECT_EQ(problem.features[known_feature], known);
  EXPECT_EQ(problem.features[unseen_feature], Point2(-9.0, -9.0));
  EXPECT_EQ(problem.feature_initialized[range_bearing_feature], 1);
  EXPECT_EQ(problem.feature_initialized[point_feature], 1);
  EXPECT_EQ(problem.feature_initialized[unseen_feature], 0);
}

TEST(Initialization, DisconnectedPoseGivesExactMessageWithItsLine) {
  // Poses with ids 0..57 on lines 1..58; pose 56 has no constraint at all.
  std::vector<Pose2> truth(58, Pose2::Zero());
  Problem2d problem;
  problem.source = "intel.g2o";
  for (int i = 0; i < 58; ++i) problem.AddPose(i, Pose2::Zero(), false, i + 1);
  for (int i = 0; i + 1 < 56; ++i) problem.relative_poses.push_back(Edge(truth, i, i + 1, 100 + i));
  problem.relative_poses.push_back(Edge(truth, 55, 57, 200));
  const Status status = InitializeProblem(&problem);
  ASSERT_TRUE(status.IsInvalidArgument()) << status.ToString();
  EXPECT_EQ(status.message(),
            "intel.g2o:57: pose 56 is not connected to the anchor (pose 0) by any constraint; "
            "expected an odometry edge or a shared landmark");
  // Rejected before any state changed.
  for (int i = 0; i < 58; ++i) EXPECT_EQ(problem.pose_initialized[i], 0);
}

TEST(Initialization, DisconnectedComponentNamesFixedAnchorAndCount) {
  // Component {0, 1} and component {2, 3, 4}; pose 3 is fixed, so {0, 1} floats.
  std::vector<Pose2> truth(5, Pose2::Zero());
  Problem2d problem = EmptyPoses(5);
  problem.pose_fixed[3] = 1;
  problem.relative_poses.push_back(Edge(truth, 0, 1));
  problem.relative_poses.push_back(Edge(truth, 2, 3));
  problem.relative_poses.push_back(Edge(truth, 3, 4));
  const Status status = InitializeProblem(&problem);
  ASSERT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(status.message(),
            "intel.g2o:1: pose 100 is not connected to the anchor (pose 103) by any constraint; "
            "expected an odometry edge or a shared landmark (1 more poses are disconnected)");
}

TEST(Initialization, SharedLandmarkOrGpsConnectsComponents) {
  std::vector<Pose2> truth{Pose2::Zero(), Pose2(1, 0, 0), Pose2(5, 5, 0), Pose2(6, 5, 0)};
  Problem2d base = EmptyPoses(4);
  base.relative_poses.push_back(Edge(truth, 0, 1));
  base.relative_poses.push_back(Edge(truth, 2, 3));
  ASSERT_FALSE(ValidateProblem(base).ok());

  // A landmark seen from pose 1 and pose 2 joins the components.
  Problem2d shared = base;
  const int32_t feature = shared.AddFeature(9, Point2::Zero(), false);
  shared.observations.push_back({.pose = 1,
                                 .feature = feature,
                                 .kind = ObservationKind::kRangeBearing,
                                 .z = Eigen::Vector2d(2.0, 0.5)});
  shared.observations.push_back({.pose = 2,
                                 .feature = feature,
                                 .kind = ObservationKind::kRangeBearing,
                                 .z = Eigen::Vector2d(3.0, -0.5)});
  ASSERT_TRUE(InitializeProblem(&shared).ok());
  // Pose 2 is reached by no chain: it starts at the nearest lower pose's guess.
  ExpectPoseNear(shared.poses[2], shared.poses[1], 0.0);
  ExpectPoseNear(shared.poses[3], Compose(shared.poses[2], Between(truth[2], truth[3])), 1e-12);
  EXPECT_LE(
      (shared.features[feature] - InvertRangeBearing(shared.poses[1], Eigen::Vector2d(2.0, 0.5)))
          .norm(),
      1e-12);

  // A GPS fix anchors the second component and seeds its guess. Once GPS
  // exists, pose 0 is no longer an implicit anchor (the gauge of
  // UnknownLayout), so the first component needs a fixed pose of its own.
  Problem2d gps = base;
  gps.gps.push_back({.pose = 2, .z = Eigen::Vector2d(5.0, 5.0), .line = 9});
  EXPECT_TRUE(InitializeProblem(&gps).IsInvalidArgument());
  gps.pose_fixed[0] = 1;
  ASSERT_TRUE(InitializeProblem(&gps).ok());
  ExpectPoseNear(gps.poses[2], Pose2(5.0, 5.0, 0.0), 0.0);
  ExpectPoseNear(gps.poses[3], Pose2(6.0, 5.0, 0.0), 1e-12);
}

TEST(Initialization, NonPositiveDefiniteInformationIsRejectedWithItsLine) {
  std::vector<Pose2> truth(3, Pose2::Zero());
  Problem2d problem = EmptyPoses(3);
  problem.relative_poses.push_back(Edge(truth, 0, 1, 11));
  problem.relative_poses.push_back(Edge(truth, 1, 2, 12));
  problem.relative_poses[1].information = Eigen::Vector3d(1.0, 1.0, -1.0).asDiagonal();
  Status status = InitializeProblem(&problem);
  ASSERT_TRUE(status.IsInvalidArgument());
  EXPECT_THAT(status.message(),
              StartsWith("intel.g2o:12: EDGE information is not positive definite"));
  EXPECT_THAT(status.message(), HasSubstr("pivot 2 is -1"));
  EXPECT_EQ(problem.pose_initialized[1], 0);

  // Singular (positive semi-definite) is rejected too.
  problem.relative_poses[1].information = Eigen::Vector3d(1.0, 0.0, 1.0).asDiagonal();
  status = InitializeProblem(&problem);
  EXPECT_THAT(status.message(),
              StartsWith("intel.g2o:12: EDGE information is not positive definite"));

  // Asymmetric and non-finite matrices.
  problem.relative_poses[1].information = Eigen::Matrix3d::Identity();
  problem.relative_poses[1].information(0, 1) = 0.5;
  EXPECT_THAT(InitializeProblem(&problem).message(),
              StartsWith("intel.g2o:12: EDGE information is not symmetric"));
  problem.relative_poses[1].information = Eigen::Matrix3d::Identity();
  problem.relative_poses[1].information(2, 2) = std::nan("");
  EXPECT_THAT(InitializeProblem(&problem).message(),
              StartsWith("intel.g2o:12: EDGE information is not finite"));

  // Observations and GPS fixes are checked the same way.
  problem.relative_poses[1].information = Eigen::Matrix3d::Identity();
  const int32_t feature = problem.AddFeature(7, Point2::Zero(), false);
  Observation observation{
      .pose = 2, .feature = feature, .z = Eigen::Vector2d(1.0, 0.0), .line = 31};
  observation.information << 1.0, 2.0, 2.0, 1.0;  // eigenvalues 3 and -1
  problem.observations.push_back(observation);
  EXPECT_THAT(InitializeProblem(&problem).message(),
              StartsWith("intel.g2o:31: EDGE information is not positive definite"));
  problem.observations.back().information.setIdentity();
  problem.gps.push_back({.pose = 1,
                         .z = Eigen::Vector2d(0, 0),
                         .information = -Eigen::Matrix2d::Identity(),
                         .line = 40});
  EXPECT_THAT(InitializeProblem(&problem).message(),
              StartsWith("intel.g2o:40: EDGE information is not positive definite"));
  problem.gps.back().information.setIdentity();
  EXPECT_TRUE(InitializeProblem(&problem).ok());
}

TEST(Initialization, OutOfRangeIndexIsRejected) {
  Problem2d problem = EmptyPoses(2);
  RelativePoseConstraint edge;
  edge.from = 0;
  edge.to = 2;
  edge.line = 5;
  problem.relative_poses.push_back(edge);
  const Status status = InitializeProblem(&problem);
  ASSERT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(status.message(), "intel.g2o:5: odometry edge refers to pose index 2, expected 0..1");
}

}  // namespace
}  // namespace graphslam::core
