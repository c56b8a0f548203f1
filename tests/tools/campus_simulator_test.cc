#include "tools/campus_simulator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include "core/gps_model.h"
#include "core/range_bearing_model.h"
#include "core/velocity_motion_model.h"

namespace graphslam::tools {
namespace {

SimulatedCampus Simulate(const CampusSimulatorOptions& options) {
  StatusOr<SimulatedCampus> campus = SimulateCampus(options);
  EXPECT_TRUE(campus.ok()) << campus.status().ToString();
  return std::move(campus).value();
}

struct Chi2 {
  double motion = 0, observation = 0, gps = 0;
  int64_t motion_dimension = 0, observation_dimension = 0, gps_dimension = 0;
  double Total() const { return motion + observation + gps; }
  int64_t Dimension() const { return motion_dimension + observation_dimension + gps_dimension; }
};

// chi2 of the TRUE state over every constraint, with the model functions.
Chi2 TrueChi2(const SimulatedCampus& campus) {
  const core::Problem2d& problem = campus.problem;
  Chi2 chi2;
  for (const core::VelocityMotionConstraint& motion : problem.motions) {
    Eigen::Vector3d residual;
    core::EvaluateVelocityMotion(campus.true_poses[motion.from], campus.true_poses[motion.to],
                                 motion.control, &residual, nullptr, nullptr);
    chi2.motion += residual.dot(motion.information * residual);
    chi2.motion_dimension += 3;
  }
  for (const core::Observation& observation : problem.observations) {
    Eigen::Vector2d residual = Eigen::Vector2d::Zero();  // unset when the model fails
    EXPECT_TRUE(core::EvaluateRangeBearing(campus.true_poses[observation.pose],
                                           campus.true_features[observation.feature],
                                           observation.z, &residual, nullptr, nullptr));
    chi2.observation += residual.dot(observation.information * residual);
    chi2.observation_dimension += 2;
  }
  for (const core::GpsConstraint& gps : problem.gps) {
    Eigen::Vector2d residual;
    core::EvaluateGps(campus.true_poses[gps.pose], gps.z, &residual, nullptr);
    chi2.gps += residual.dot(gps.information * residual);
    chi2.gps_dimension += 2;
  }
  return chi2;
}

TEST(CampusSimulator, SameSeedGivesIdenticalProblems) {
  CampusSimulatorOptions options;
  options.poses = 1500;
  options.runs = 2;
  options.gps_every = 7;
  const SimulatedCampus a = Simulate(options);
  const SimulatedCampus b = Simulate(options);
  ASSERT_EQ(a.problem.num_poses(), b.problem.num_poses());
  ASSERT_EQ(a.problem.num_features(), b.problem.num_features());
  ASSERT_EQ(a.problem.observations.size(), b.problem.observations.size());
  ASSERT_EQ(a.problem.motions.size(), b.problem.motions.size());
  ASSERT_EQ(a.problem.gps.size(), b.problem.gps.size());
  for (int32_t i = 0; i < a.problem.num_poses(); ++i) {
    EXPECT_EQ(a.true_poses[i], b.true_poses[i]) << "pose " << i;
    EXPECT_EQ(a.problem.poses[i], b.problem.poses[i]) << "pose " << i;
  }
  for (int32_t i = 0; i < a.problem.num_features(); ++i) {
    EXPECT_EQ(a.true_features[i], b.true_features[i]) << "feature " << i;
    EXPECT_EQ(a.problem.features[i], b.problem.features[i]) << "feature " << i;
  }
  for (size_t i = 0; i < a.problem.observations.size(); ++i) {
    EXPECT_EQ(a.problem.observations[i].z, b.problem.observations[i].z) << "observation " << i;
    EXPECT_EQ(a.problem.observations[i].feature, b.problem.observations[i].feature);
  }
  for (size_t i = 0; i < a.problem.motions.size(); ++i) {
    EXPECT_EQ(a.problem.motions[i].control.omega, b.problem.motions[i].control.omega);
    EXPECT_EQ(a.problem.motions[i].information, b.problem.motions[i].information);
  }
  for (size_t i = 0; i < a.problem.gps.size(); ++i) EXPECT_EQ(a.problem.gps[i].z, b.problem.gps[i].z);

  options.seed = 2;
  const SimulatedCampus c = Simulate(options);
  EXPECT_NE(a.true_poses.back(), c.true_poses.back());
}

TEST(CampusSimulator, ChiSquareOfTheTruthPerDimensionIsAboutOne) {
  CampusSimulatorOptions options;
  options.poses = 4000;
  options.runs = 2;
  options.gps_every = 10;
  const SimulatedCampus campus = Simulate(options);
  const Chi2 chi2 = TrueChi2(campus);
  ASSERT_GT(chi2.Dimension(), 0);
  const double total = chi2.Total() / static_cast<double>(chi2.Dimension());
  const double motion = chi2.motion / static_cast<double>(chi2.motion_dimension);
  const double observation = chi2.observation / static_cast<double>(chi2.observation_dimension);
  const double gps = chi2.gps / static_cast<double>(chi2.gps_dimension);
  EXPECT_GE(total, 0.9);
  EXPECT_LE(total, 1.1);
  // Each kind on its own, too (12000 and ~60000 dimensions: sd ~0.013, ~0.006).
  EXPECT_GE(motion, 0.9);
  EXPECT_LE(motion, 1.1);
  EXPECT_GE(observation, 0.9);
  EXPECT_LE(observation, 1.1);
  EXPECT_GE(gps, 0.8);  // 800 dimensions: sd 0.05
  EXPECT_LE(gps, 1.2);
}

TEST(CampusSimulator, ChiSquareHoldsWithTheLooseCoreNoise) {
  CampusSimulatorOptions options;
  options.poses = 3000;
  options.noise = core::VelocityNoise();  // a1..a6 = 0.1, 0.01, ... (much noisier)
  const SimulatedCampus campus = Simulate(options);
  const Chi2 chi2 = TrueChi2(campus);
  const double motion = chi2.motion / static_cast<double>(chi2.motion_dimension);
  // With a1 = 0.1 the second-order cross term n_v n_w of the motion adds ~10 %
  // to the cross-track variance, ~3-5 % to chi2/dof (campus_simulator.h).
  EXPECT_GE(motion, 0.95);
  EXPECT_LE(motion, 1.2);
}

TEST(CampusSimulator, EveryObservationIsWithinRangeAndFieldOfView) {
  CampusSimulatorOptions options;
  options.poses = 2000;
  const SimulatedCampus campus = Simulate(options);
  ASSERT_GT(campus.problem.observations.size(), 0u);
  for (const core::Observation& observation : campus.problem.observations) {
    const core::Pose2& pose = campus.true_poses[observation.pose];
    const core::Point2 delta = campus.true_features[observation.feature] - pose.head<2>();
    const double bearing = core::WrapAngle(std::atan2(delta.y(), delta.x()) - pose.z());
    EXPECT_LE(delta.norm(), options.sensor_range);
    EXPECT_LE(std::abs(bearing), 0.5 * options.field_of_view + 1e-12);
    EXPECT_GT(observation.z(0), 0.0);
    EXPECT_GT(observation.z(1), -std::numbers::pi);
    EXPECT_LE(observation.z(1), std::numbers::pi);
    EXPECT_EQ(observation.kind, core::ObservationKind::kRangeBearing);
    EXPECT_DOUBLE_EQ(observation.information(0, 0), 1.0 / (0.1 * 0.1));
    EXPECT_DOUBLE_EQ(observation.information(1, 1), 1.0 / (0.02 * 0.02));
  }
  // A few landmarks per pose: the sensor sees both sides of the street ahead.
  const double per_pose = static_cast<double>(campus.problem.observations.size()) /
                          campus.problem.num_poses();
  EXPECT_GT(per_pose, 3.0);
}

TEST(CampusSimulator, TheRobotRevisitsStreets) {
  CampusSimulatorOptions options;
  options.poses = 2000;
  const SimulatedCampus campus = Simulate(options);
  const int32_t features = campus.problem.num_features();
  std::vector<int32_t> first(features, -1), last(features, -1);
  for (const core::Observation& observation : campus.problem.observations) {
    if (first[observation.feature] < 0) first[observation.feature] = observation.pose;
    last[observation.feature] = observation.pose;
  }
  int64_t loop_landmarks = 0;
  for (int32_t i = 0; i < features; ++i) {
    if (first[i] >= 0 && last[i] - first[i] > 200) ++loop_landmarks;
  }
  EXPECT_GT(loop_landmarks, features / 4) << "of " << features << " landmarks";
  EXPECT_GT(campus.observed_features, features * 3 / 4);
}

TEST(CampusSimulator, TheRobotStaysOnTheStreets) {
  CampusSimulatorOptions options;
  options.poses = 3000;
  options.runs = 3;
  const SimulatedCampus campus = Simulate(options);
  const double b = options.block_size;
  const double max_x = (campus.grid_columns - 1) * b, max_y = (campus.grid_rows - 1) * b;
  for (size_t i = 0; i < campus.true_poses.size(); ++i) {
    const core::Pose2& pose = campus.true_poses[i];
    const double off_x = std::abs(pose.x() - b * std::round(pose.x() / b));
    const double off_y = std::abs(pose.y() - b * std::round(pose.y() / b));
    // Quarter-circle turns of radius 6 m cut corners by 6 (1 - 1/sqrt 2) = 1.8 m.
    EXPECT_LE(std::min(off_x, off_y), 3.0) << "pose " << i << " at " << pose.transpose();
    EXPECT_GE(pose.x(), -3.0);
    EXPECT_GE(pose.y(), -3.0);
    EXPECT_LE(pose.x(), max_x + 3.0);
    EXPECT_LE(pose.y(), max_y + 3.0);
  }
  EXPECT_NEAR(campus.distance_travelled, (options.poses - options.runs) * options.speed * options.dt,
              0.05 * options.poses);
}

TEST(CampusSimulator, GpsFixesEveryKthPoseOfEachRun) {
  CampusSimulatorOptions options;
  options.poses = 1001;
  options.runs = 3;  // 334, 334, 333 poses
  options.gps_every = 10;
  const SimulatedCampus campus = Simulate(options);
  EXPECT_EQ(campus.problem.gps.size(), 34u + 34u + 34u);
  for (const core::GpsConstraint& gps : campus.problem.gps) {
    EXPECT_LT((gps.z - campus.true_poses[gps.pose].head<2>()).norm(), 6.0 * options.gps_sigma);
    EXPECT_DOUBLE_EQ(gps.information(0, 0), 1.0);
  }
  // With GPS nothing is fixed; without it the first pose anchors the map.
  for (uint8_t fixed : campus.problem.pose_fixed) EXPECT_EQ(fixed, 0);
  options.gps_every = 0;
  const SimulatedCampus anchored = Simulate(options);
  EXPECT_TRUE(anchored.problem.gps.empty());
  EXPECT_EQ(anchored.problem.pose_fixed[0], 1);
}

TEST(CampusSimulator, LayoutIdsStampsAndInitialGuesses) {
  CampusSimulatorOptions options;
  options.poses = 900;
  options.runs = 3;
  options.features = 321;
  const SimulatedCampus campus = Simulate(options);
  const core::Problem2d& problem = campus.problem;
  ASSERT_EQ(problem.num_features(), 321);
  ASSERT_EQ(campus.true_features.size(), 321u);
  ASSERT_EQ(problem.num_poses(), 900);
  ASSERT_EQ(campus.run_of_pose.size(), 900u);
  EXPECT_EQ(problem.motions.size(), 900u - 3u);
  for (int32_t i = 0; i < problem.num_features(); ++i) {
    EXPECT_EQ(problem.feature_ids[i], 1000000 + i);
    EXPECT_EQ(problem.feature_initialized[i], 0);
  }
  int64_t initialized = 0;
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    EXPECT_EQ(problem.pose_ids[i], i);
    const int32_t k = i % 300;  // 300 poses per run
    EXPECT_EQ(campus.run_of_pose[i], i / 300);
    EXPECT_DOUBLE_EQ(problem.pose_stamps[i], k * options.dt);
    EXPECT_EQ(problem.pose_initialized[i], k == 0 ? 1 : 0) << "pose " << i;
    initialized += problem.pose_initialized[i];
  }
  EXPECT_EQ(initialized, 3);
  EXPECT_EQ(problem.poses[0], campus.true_poses[0]);  // run 1 starts at the truth
  EXPECT_EQ(problem.pose_fixed[0], 1);
  EXPECT_NE(problem.poses[300], campus.true_poses[300]);  // later runs: truth + noise
  EXPECT_LT((problem.poses[300] - campus.true_poses[300]).head<2>().norm(), 12.0);
  // Motions chain consecutive poses of one run only.
  for (const core::VelocityMotionConstraint& motion : problem.motions) {
    EXPECT_EQ(motion.to, motion.from + 1);
    EXPECT_EQ(campus.run_of_pose[motion.from], campus.run_of_pose[motion.to]);
    EXPECT_DOUBLE_EQ(motion.control.v, options.speed);
    EXPECT_DOUBLE_EQ(motion.control.dt, options.dt);
  }
}

TEST(CampusSimulator, FeatureCountDerivedFromThePosesGrowsWithThem) {
  CampusSimulatorOptions small;
  small.poses = 500;
  CampusSimulatorOptions large;
  large.poses = 20000;
  const SimulatedCampus a = Simulate(small);
  const SimulatedCampus b = Simulate(large);
  EXPECT_GE(a.grid_columns, 3);
  EXPECT_GT(b.problem.num_features(), 2 * a.problem.num_features());
}

TEST(CampusSimulator, ValidateRejectsBadOptions) {
  EXPECT_TRUE(CampusSimulatorOptions().Validate().ok());
  auto rejects = [](auto mutate, const char* field) {
    CampusSimulatorOptions options;
    mutate(options);
    const Status status = options.Validate();
    EXPECT_TRUE(status.IsInvalidArgument()) << field;
    EXPECT_NE(status.message().find(field), std::string::npos) << status.message();
    EXPECT_FALSE(SimulateCampus(options).ok()) << field;
  };
  rejects([](CampusSimulatorOptions& o) { o.runs = 0; }, "runs");
  rejects([](CampusSimulatorOptions& o) { o.poses = 3; o.runs = 2; }, "poses");
  rejects([](CampusSimulatorOptions& o) { o.features = -1; }, "features");
  rejects([](CampusSimulatorOptions& o) { o.gps_every = -2; }, "gps_every");
  rejects([](CampusSimulatorOptions& o) { o.street_width = 50; }, "street_width");
  rejects([](CampusSimulatorOptions& o) { o.dt = 0; }, "dt");
  rejects([](CampusSimulatorOptions& o) { o.range_sigma = -1; }, "range_sigma");
  rejects([](CampusSimulatorOptions& o) { o.speed = std::numeric_limits<double>::quiet_NaN(); },
          "speed");
  rejects([](CampusSimulatorOptions& o) { o.max_landmark_spacing = 1; }, "max_landmark_spacing");
  rejects([](CampusSimulatorOptions& o) { o.noise.alpha[2] = -0.1; }, "a3");
  rejects([](CampusSimulatorOptions& o) { o.poses = 2000000; }, "feature_id_base");
}

}  // namespace
}  // namespace graphslam::tools
