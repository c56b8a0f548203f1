#include "storage/g2o_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/LU>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "core/se2.h"
#include "core/velocity_motion_model.h"
#include "storage/g2o_reader.h"
#include "tests/testing/datasets.h"
#include "tests/testing/numeric_diff.h"

namespace graphslam::storage {
namespace {

using testing::DatasetPath;

std::string TempPath(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("graphslam_g2o_writer_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void ExpectSameProblem(const core::Problem2d& a, const core::Problem2d& b, double tolerance) {
  ASSERT_EQ(a.num_poses(), b.num_poses());
  ASSERT_EQ(a.num_features(), b.num_features());
  EXPECT_EQ(a.pose_ids, b.pose_ids);
  EXPECT_EQ(a.feature_ids, b.feature_ids);
  EXPECT_EQ(a.pose_fixed, b.pose_fixed);
  for (int32_t i = 0; i < a.num_poses(); ++i) {
    ASSERT_LE((a.poses[i] - b.poses[i]).cwiseAbs().maxCoeff(), tolerance) << "pose " << i;
  }
  for (int32_t i = 0; i < a.num_features(); ++i) {
    ASSERT_LE((a.features[i] - b.features[i]).cwiseAbs().maxCoeff(), tolerance);
  }
  ASSERT_EQ(a.relative_poses.size(), b.relative_poses.size());
  for (size_t k = 0; k < a.relative_poses.size(); ++k) {
    ASSERT_EQ(a.relative_poses[k].from, b.relative_poses[k].from);
    ASSERT_EQ(a.relative_poses[k].to, b.relative_poses[k].to);
    ASSERT_LE((a.relative_poses[k].z - b.relative_poses[k].z).cwiseAbs().maxCoeff(), tolerance);
    ASSERT_LE((a.relative_poses[k].information - b.relative_poses[k].information)
                  .cwiseAbs()
                  .maxCoeff(),
              tolerance * a.relative_poses[k].information.cwiseAbs().maxCoeff());
  }
  ASSERT_EQ(a.observations.size(), b.observations.size());
  for (size_t k = 0; k < a.observations.size(); ++k) {
    ASSERT_EQ(a.observations[k].pose, b.observations[k].pose);
    ASSERT_EQ(a.observations[k].feature, b.observations[k].feature);
    ASSERT_LE((a.observations[k].z - b.observations[k].z).cwiseAbs().maxCoeff(), tolerance);
    ASSERT_LE(
        (a.observations[k].information - b.observations[k].information).cwiseAbs().maxCoeff(),
        tolerance);
  }
}

TEST(G2oWriter, VictoriaParkRoundTripIsExact) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  const auto original = ReadG2o(DatasetPath("victoria_park/victoriaPark-full.g2o"));
  ASSERT_TRUE(original.ok()) << original.status().ToString();
  const std::string path = TempPath("victoria.g2o");
  ASSERT_TRUE(WriteG2o(*original, path).ok());
  const auto back = ReadG2o(path);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ExpectSameProblem(*original, *back, 1e-12);
}

core::Problem2d SmallProblem() {
  core::Problem2d problem;
  problem.AddPose(10, core::Pose2(0.1, 1.0 / 3.0, 0.7), true, 0);
  problem.AddPose(11, core::Pose2(1.0, 0.5, 1.1), true, 0);
  problem.AddPose(12, core::Pose2(2.0, 0.8, -3.0), false, 0);
  problem.pose_fixed[0] = 1;
  problem.AddFeature(100, core::Point2(3.0, 4.0), true);
  core::RelativePoseConstraint relative;
  relative.from = 0;
  relative.to = 1;
  relative.z = core::Pose2(0.9, 0.1, 0.4);
  relative.information << 50, 1, 2, 1, 60, 3, 2, 3, 70;
  problem.relative_poses.push_back(relative);
  core::VelocityMotionConstraint motion;
  motion.from = 1;
  motion.to = 2;
  motion.control = {1.2, 0.3, 0.8};
  motion.information << 400, 20, 5, 20, 300, 7, 5, 7, 900;
  problem.motions.push_back(motion);
  core::Observation range_bearing;
  range_bearing.pose = 1;
  range_bearing.feature = 0;
  range_bearing.kind = core::ObservationKind::kRangeBearing;
  range_bearing.z = Eigen::Vector2d(3.5, 0.6);
  range_bearing.information << 100, 0, 0, 400;
  problem.observations.push_back(range_bearing);
  core::GpsConstraint gps;
  gps.pose = 2;
  gps.z = Eigen::Vector2d(2.1, 0.7);
  gps.information << 4, 1, 1, 4;
  problem.gps.push_back(gps);
  return problem;
}

TEST(G2oWriter, ConvertsMotionAndRangeBearingAndGps) {
  const core::Problem2d problem = SmallProblem();
  const std::string path = TempPath("small.g2o");
  ASSERT_TRUE(WriteG2o(problem, path).ok());
  const auto back = ReadG2o(path);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->pose_ids, problem.pose_ids);
  EXPECT_EQ(back->poses[0], problem.poses[0]);  // %.17g: bit-exact
  EXPECT_EQ(back->pose_fixed, problem.pose_fixed);
  ASSERT_EQ(back->relative_poses.size(), 2u);  // relative pose + motion
  EXPECT_EQ(back->relative_poses[0].information, problem.relative_poses[0].information);

  // Motion: z = g(u, 0); Omega rotated by phi = theta_from + z_theta.
  const core::VelocityMotionConstraint& motion = problem.motions[0];
  const core::Pose2 z = core::PredictVelocityMotion(core::Pose2::Zero(), motion.control);
  EXPECT_LE((back->relative_poses[1].z - z).norm(), 1e-12);
  // z does not depend on the pose it starts from.
  const core::Pose2 start = problem.poses[1];
  EXPECT_LE((core::Between(start, core::PredictVelocityMotion(start, motion.control)) - z).norm(),
            1e-12);
  // chi2 agrees to first order: e_w = x_t - g(u, x_{t-1}) with Omega_w against
  // the g2o residual with the written Omega, for a small perturbation.
  const Eigen::Matrix3d& omega = back->relative_poses[1].information;
  const Eigen::Vector3d delta(1e-5, -2e-5, 3e-5);
  const core::Pose2 current = core::PredictVelocityMotion(start, motion.control) + delta;
  Eigen::Vector3d e_world = current - core::PredictVelocityMotion(start, motion.control);
  const core::Pose2 measured = core::Between(start, current);
  const core::Pose2 e_g2o = core::Between(z, measured);
  const double chi2_world = e_world.dot(motion.information * e_world);
  const double chi2_g2o = e_g2o.dot(omega * e_g2o);
  EXPECT_NEAR(chi2_g2o / chi2_world, 1.0, 1e-4);

  // Range-bearing: p = r (cos phi, sin phi), Omega_p = J^-T Omega_rb J^-1 with
  // J checked against central differences.
  const core::Observation& rb = problem.observations[0];
  ASSERT_EQ(back->observations.size(), 1u);
  const core::Observation& xy = back->observations[0];
  EXPECT_EQ(xy.kind, core::ObservationKind::kPointXY);
  EXPECT_LE((xy.z - Eigen::Vector2d(3.5 * std::cos(0.6), 3.5 * std::sin(0.6))).norm(), 1e-12);
  const Eigen::MatrixXd jacobian = testing::NumericJacobian(
      [](const Eigen::VectorXd& polar) {
        Eigen::VectorXd point(2);
        point << polar[0] * std::cos(polar[1]), polar[0] * std::sin(polar[1]);
        return point;
      },
      Eigen::Vector2d(rb.z));
  const Eigen::Matrix2d j = jacobian;
  const Eigen::Matrix2d covariance = j * rb.information.inverse() * j.transpose();
  EXPECT_LE((xy.information - covariance.inverse()).norm(), 1e-6 * xy.information.norm());

  ASSERT_EQ(back->gps.size(), 1u);
  EXPECT_EQ(back->gps[0].z, problem.gps[0].z);
  EXPECT_EQ(back->gps[0].information, problem.gps[0].information);
}

TEST(G2oWriter, RejectsBadProblemsBeforeWriting) {
  const std::string path = TempPath("rejected.g2o");
  std::ofstream(path) << "old\n";
  core::Problem2d duplicate = SmallProblem();
  duplicate.AddFeature(100, core::Point2(1.0, 1.0), true);
  EXPECT_EQ(WriteG2o(duplicate, path).message(),
            "writing " + path + ": feature id 100 appears twice; expected unique feature ids");
  core::Problem2d zero_range = SmallProblem();
  zero_range.observations[0].z.x() = 0.0;
  EXPECT_TRUE(WriteG2o(zero_range, path).IsInvalidArgument());
  core::Problem2d bad_index = SmallProblem();
  bad_index.relative_poses[0].to = 3;
  EXPECT_EQ(WriteG2o(bad_index, path).message(),
            "writing " + path + ": relative_poses[0].to is 3; expected an index in [0, 3) "
                                "(num_poses)");
  EXPECT_EQ(Slurp(path), "old\n");
}

TEST(G2oWriter, DiskFailureKeepsThePreviousFile) {
  const std::string path = TempPath("kept.g2o");
  ASSERT_TRUE(WriteG2o(SmallProblem(), path).ok());
  const std::string before = Slurp(path);
  core::Problem2d changed = SmallProblem();
  changed.poses[1].x() = 99.0;
  for (auto operation : {FaultInjectionEnv::Operation::kAppend,
                         FaultInjectionEnv::Operation::kSync,
                         FaultInjectionEnv::Operation::kRename}) {
    FaultInjectionEnv env(Env::Default());
    env.FailAt(operation, 1);
    EXPECT_TRUE(WriteG2o(changed, path, &env).IsIOError());
    EXPECT_EQ(Slurp(path), before);
    const auto still = ReadG2o(path);  // the previous file still loads
    ASSERT_TRUE(still.ok());
    EXPECT_EQ(still->poses[1].x(), 1.0);
  }
}

}  // namespace
}  // namespace graphslam::storage

namespace graphslam::storage {
namespace {

// Issue 22: a feature id that is also a pose id (MRCLAM: poses 0..n-1,
// landmarks 6..20) does not make the write fail; the features are numbered
// past the largest pose id, and a comment line says by how much.
TEST(G2oWriter, CollidingFeatureIdsAreRenumberedPastThePoses) {
  core::Problem2d problem = SmallProblem();  // poses 10, 11, 12
  problem.feature_ids[0] = 11;
  problem.AddFeature(9, core::Point2(5.0, 6.0), true);
  core::Observation second = problem.observations[0];
  second.feature = 1;
  problem.observations.push_back(second);
  StatusOr<int64_t> offset = G2oFeatureIdOffset(problem);
  ASSERT_TRUE(offset.ok());
  EXPECT_EQ(*offset, 12 + 1 - 9);  // the smallest feature id 9 becomes 13
  const std::string path = TempPath("renumbered.g2o");
  ASSERT_TRUE(WriteG2o(problem, path).ok());
  const std::string text = Slurp(path);
  EXPECT_EQ(text.substr(0, text.find('\n')),
            "# graphslam: feature ids renumbered: VERTEX_XY id = feature id + 4");
  const auto back = ReadG2o(path);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  EXPECT_EQ(back->pose_ids, problem.pose_ids);
  ASSERT_EQ(back->feature_ids.size(), 2u);
  EXPECT_EQ(back->feature_ids[0], 15);
  EXPECT_EQ(back->feature_ids[1], 13);
  EXPECT_EQ(back->features[1], problem.features[1]);
  ASSERT_EQ(back->observations.size(), 2u);
  EXPECT_EQ(back->feature_ids[back->observations[1].feature], 13);
  // Disjoint ids: written as they are, no comment line.
  EXPECT_EQ(*G2oFeatureIdOffset(SmallProblem()), 0);
  ASSERT_TRUE(WriteG2o(SmallProblem(), path).ok());
  EXPECT_EQ(Slurp(path).rfind("VERTEX_SE2 10 ", 0), 0u);
  // Renumbering that would overflow int64 is refused, naming the ids.
  problem.feature_ids[0] = std::numeric_limits<int64_t>::max();
  problem.feature_ids[1] = 11;
  EXPECT_TRUE(G2oFeatureIdOffset(problem).status().IsInvalidArgument());
}

}  // namespace
}  // namespace graphslam::storage
