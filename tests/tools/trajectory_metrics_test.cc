#include "tools/trajectory_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <random>
#include <string>
#include <unistd.h>

#include "core/angle.h"
#include "core/problem.h"
#include "storage/features_csv_writer.h"
#include "storage/tum_writer.h"

namespace graphslam::tools {
namespace {

// A per-test scratch folder, removed afterwards.
class ScratchDir {
 public:
  ScratchDir() {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::temp_directory_path() /
            ("graphslam_trajectory_metrics_" + std::string(info->name()) + "_" +
             std::to_string(::getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() { std::filesystem::remove_all(path_); }
  std::string File(const std::string& name, const std::string& contents) const {
    const std::string path = (path_ / name).string();
    std::ofstream(path) << contents;
    return path;
  }
  std::string Path(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

// A wiggly trajectory at 10 Hz.
std::vector<StampedPose2> Trajectory(int n, double t0 = 0.0) {
  std::vector<StampedPose2> poses;
  for (int i = 0; i < n; ++i) {
    const double t = t0 + 0.1 * i;
    poses.push_back(StampedPose2{
        t, core::Pose2(10.0 * std::cos(0.05 * i) + 0.01 * i, 5.0 * std::sin(0.03 * i),
                       core::WrapAngle(0.02 * i))});
  }
  return poses;
}

std::vector<StampedPose2> Transformed(const std::vector<StampedPose2>& poses,
                                      const core::Pose2& transform) {
  std::vector<StampedPose2> out = poses;
  for (StampedPose2& pose : out) pose.pose = core::Compose(transform, pose.pose);
  return out;
}

TEST(TrajectoryMetrics, RigidCopyAlignsToZeroError) {
  const std::vector<StampedPose2> truth = Trajectory(500);
  const core::Pose2 transform(12.5, -3.25, 0.7);
  const std::vector<StampedPose2> estimated = Transformed(truth, transform);
  StatusOr<TrajectoryErrors> errors = CompareTrajectories(estimated, truth);
  ASSERT_TRUE(errors.ok()) << errors.status().ToString();
  EXPECT_EQ(errors->matched, 500);
  EXPECT_EQ(errors->unmatched, 0);
  EXPECT_EQ(errors->runs, 1);
  EXPECT_LT(errors->position_rmse, 1e-9);
  EXPECT_LT(errors->heading_rmse_rad, 1e-9);
  // The alignment is the inverse transform.
  const core::Pose2 inverse = core::Inverse(transform);
  EXPECT_NEAR(errors->alignment.translation().x(), inverse.x(), 1e-9);
  EXPECT_NEAR(errors->alignment.translation().y(), inverse.y(), 1e-9);
  EXPECT_NEAR(RotationAngle(errors->alignment), inverse.z(), 1e-12);

  // Without alignment the offset shows.
  TrajectoryMatchOptions raw;
  raw.align = false;
  StatusOr<TrajectoryErrors> unaligned = CompareTrajectories(estimated, truth, raw);
  ASSERT_TRUE(unaligned.ok());
  EXPECT_GT(unaligned->position_rmse, 1.0);
  EXPECT_NEAR(unaligned->heading_rmse_rad, 0.7, 1e-12);
}

TEST(TrajectoryMetrics, NoisyCopyHasTheExpectedRmse) {
  const int n = 20000;
  const double sigma_xy = 0.1, sigma_theta = 0.01;
  const std::vector<StampedPose2> truth = Trajectory(n);
  std::vector<StampedPose2> estimated = Transformed(truth, core::Pose2(-4.0, 9.0, -2.0));
  std::mt19937_64 engine(7);
  std::normal_distribution<double> normal;
  for (StampedPose2& pose : estimated) {
    pose.pose.x() += sigma_xy * normal(engine);
    pose.pose.y() += sigma_xy * normal(engine);
    pose.pose.z() = core::WrapAngle(pose.pose.z() + sigma_theta * normal(engine));
  }
  StatusOr<TrajectoryErrors> errors = CompareTrajectories(estimated, truth);
  ASSERT_TRUE(errors.ok());
  // E|e|^2 = 2 sigma^2 per point (minus 3 of 2n dof for the fit): RMSE = sqrt(2) sigma.
  // The sample RMSE has relative sd ~ 1/sqrt(2 * 2n) = 0.35%; 2% is > 5 sd.
  EXPECT_NEAR(errors->position_rmse, std::sqrt(2.0) * sigma_xy, 0.02 * std::sqrt(2.0) * sigma_xy);
  EXPECT_NEAR(errors->heading_rmse_rad, sigma_theta, 0.03 * sigma_theta);
  EXPECT_NEAR(errors->position_mean, std::sqrt(std::numbers::pi / 2.0) * sigma_xy,
              0.03 * sigma_xy);  // Rayleigh mean
}

// Two runs moved by one rigid transform align jointly to zero error; when one
// of them is misplaced relative to the other (shifted by 1 m), each run alone
// still aligns to zero, but the joint alignment shows the misplacement.
TEST(TrajectoryMetrics, JointAlignmentOfSeveralRunsShowsAMisplacedRun) {
  const std::vector<StampedPose2> truth_a = Trajectory(400);
  std::vector<StampedPose2> truth_b = Trajectory(400);
  for (StampedPose2& pose : truth_b) pose.pose = core::Compose(core::Pose2(3.0, 20.0, 1.0), pose.pose);
  const core::Pose2 transform(12.5, -3.25, 0.7);
  std::vector<std::vector<StampedPose2>> estimated = {Transformed(truth_a, transform),
                                                      Transformed(truth_b, transform)};
  const std::vector<std::vector<StampedPose2>> truth = {truth_a, truth_b};
  StatusOr<JointTrajectoryErrors> joint = CompareTrajectoriesJointly(estimated, truth);
  ASSERT_TRUE(joint.ok()) << joint.status().ToString();
  EXPECT_EQ(joint->matched, 800);
  ASSERT_EQ(joint->runs.size(), 2u);
  EXPECT_LT(joint->position_rmse, 1e-9);
  EXPECT_LT(joint->heading_rmse_rad, 1e-9);
  EXPECT_NEAR(RotationAngle(joint->alignment), core::Inverse(transform).z(), 1e-12);

  for (StampedPose2& pose : estimated[1]) pose.pose.x() += 1.0;
  joint = CompareTrajectoriesJointly(estimated, truth);
  ASSERT_TRUE(joint.ok());
  StatusOr<TrajectoryErrors> alone = CompareTrajectories(estimated[1], truth_b);
  ASSERT_TRUE(alone.ok());
  EXPECT_LT(alone->position_rmse, 1e-9);
  // Half the points 1 m off: a translation-only fit leaves 0.5 m; the
  // rotation can take a little more off.
  EXPECT_GT(joint->position_rmse, 0.3);
  EXPECT_LE(joint->position_rmse, 0.5 + 1e-9);
  EXPECT_GT(joint->runs[0].position_rmse, 0.2);
  EXPECT_GT(joint->runs[1].position_rmse, 0.2);
  EXPECT_NEAR(joint->position_rmse * joint->position_rmse * 800,
              (joint->runs[0].position_rmse * joint->runs[0].position_rmse +
               joint->runs[1].position_rmse * joint->runs[1].position_rmse) * 400,
              1e-9);
  EXPECT_FALSE(CompareTrajectoriesJointly(estimated, {truth_a}).ok());
}

TEST(TrajectoryMetrics, MatchesByNearestStampWithinTolerance) {
  // Ground truth at 100 Hz over 0..10 s; the estimate at 10 Hz over -1..12 s,
  // offset by 2 ms: only stamps inside the ground truth's span match.
  std::vector<StampedPose2> truth;
  for (int i = 0; i <= 1000; ++i) {
    const double t = 0.01 * i;
    truth.push_back(StampedPose2{t, core::Pose2(t, 0.5 * t * t, 0.1 * t)});
  }
  std::vector<StampedPose2> estimated;
  for (int i = -10; i <= 120; ++i) {
    const double t = 0.1 * i + 0.002;
    estimated.push_back(StampedPose2{t, core::Pose2(t, 0.5 * t * t, 0.1 * t)});
  }
  StatusOr<TrajectoryErrors> errors = CompareTrajectories(estimated, truth);
  ASSERT_TRUE(errors.ok());
  EXPECT_NEAR(errors->max_time_difference, 0.005, 1e-12);  // half the 10 ms spacing
  // t = 0.002 .. 10.002 (the last 2 ms past the end of the ground truth).
  EXPECT_EQ(errors->matched, 101);
  EXPECT_EQ(errors->unmatched, 30);
  // Matched to the pose 2 ms earlier: a small, non-zero error.
  EXPECT_GT(errors->position_rmse, 0.0);
  EXPECT_LT(errors->position_rmse, 0.03);
  for (size_t k = 0; k < errors->estimated_index.size(); ++k) {
    EXPECT_NEAR(estimated[errors->estimated_index[k]].stamp,
                truth[errors->ground_truth_index[k]].stamp, 0.0021);
  }

  TrajectoryMatchOptions strict;
  strict.max_time_difference = 0.001;
  EXPECT_TRUE(CompareTrajectories(estimated, truth, strict).status().IsInvalidArgument());
}

TEST(TrajectoryMetrics, RunsWhoseStampsRestartAreMatchedRunByRun) {
  // Two runs with the same stamps 0..49.9 s: each pose must find its own run.
  std::vector<StampedPose2> truth = Trajectory(500);
  const std::vector<StampedPose2> second = Transformed(Trajectory(500), core::Pose2(100, 0, 1));
  truth.insert(truth.end(), second.begin(), second.end());
  const std::vector<StampedPose2> estimated = Transformed(truth, core::Pose2(1, 2, 0.3));
  StatusOr<TrajectoryErrors> errors = CompareTrajectories(estimated, truth);
  ASSERT_TRUE(errors.ok());
  EXPECT_EQ(errors->runs, 2);
  EXPECT_EQ(errors->matched, 1000);
  EXPECT_LT(errors->position_rmse, 1e-9);

  const std::vector<StampedPose2> one_run = Trajectory(500);
  const Status mismatch = CompareTrajectories(one_run, truth).status();
  EXPECT_TRUE(mismatch.IsInvalidArgument());
  EXPECT_NE(mismatch.message().find("1 runs but the ground truth 2"), std::string::npos)
      << mismatch.message();
  EXPECT_TRUE(CompareTrajectories({}, truth).status().IsInvalidArgument());
  EXPECT_TRUE(CompareTrajectories(truth, {}).status().IsInvalidArgument());
}

TEST(TrajectoryMetrics, AlignRigidSmallCases) {
  EXPECT_TRUE(AlignRigid({}, {}).isApprox(Eigen::Isometry2d::Identity()));
  const Eigen::Isometry2d one = AlignRigid({core::Point2(1, 2)}, {core::Point2(4, -1)});
  EXPECT_TRUE((one * core::Point2(1, 2)).isApprox(core::Point2(4, -1)));
  EXPECT_NEAR(RotationAngle(one), 0.0, 1e-15);
}

TEST(TrajectoryMetrics, FeatureRmseUsesTheGivenTransformAndMatchesIds) {
  std::map<int64_t, core::Point2> truth = {{6, core::Point2(0, 0)},
                                           {7, core::Point2(10, 0)},
                                           {8, core::Point2(0, 10)},
                                           {9, core::Point2(5, 5)}};
  const core::Pose2 transform(3, -2, 0.4);
  std::map<int64_t, core::Point2> estimated;
  for (const auto& [id, position] : truth) {
    estimated[id] = core::TransformPoint(core::Inverse(transform), position);
  }
  estimated[42] = core::Point2(1, 1);  // not in the ground truth
  truth.erase(9);                      // 9 is estimated only: extra, like 42
  truth[10] = core::Point2(7, 7);      // missing from the estimate

  Eigen::Isometry2d exact = Eigen::Isometry2d::Identity();
  exact.linear() = core::Rotation2(transform.z());
  exact.translation() = transform.head<2>();
  int64_t matched = 0;
  EXPECT_LT(FeatureRmse(estimated, truth, exact, &matched), 1e-12);
  EXPECT_EQ(matched, 3);
  // The identity leaves the offset.
  EXPECT_GT(FeatureRmse(estimated, truth, Eigen::Isometry2d::Identity()), 1.0);

  const FeatureErrors errors = CompareFeatures(estimated, truth, Eigen::Isometry2d::Identity());
  EXPECT_EQ(errors.matched, 3);
  EXPECT_EQ(errors.missing, 1);
  EXPECT_EQ(errors.extra, 2);
  EXPECT_GT(errors.rmse_trajectory_aligned, 1.0);
  EXPECT_LT(errors.rmse_self_aligned, 1e-9);
  EXPECT_TRUE(std::isnan(FeatureRmse({}, truth, exact)));
}

TEST(TrajectoryMetrics, ReadTumRoundTripsWriteTum) {
  ScratchDir dir;
  core::Problem2d problem;
  for (int i = 0; i < 50; ++i) {
    problem.AddPose(i, core::Pose2(0.5 * i, -0.25 * i, core::WrapAngle(0.3 * i)), true, 0, 0.1 * i);
  }
  const std::string path = dir.Path("t.tum");
  ASSERT_TRUE(storage::WriteTum(problem, path).ok());
  StatusOr<std::vector<StampedPose2>> read = ReadTum(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->size(), 50u);
  for (int i = 0; i < 50; ++i) {
    EXPECT_DOUBLE_EQ((*read)[i].stamp, 0.1 * i);
    EXPECT_NEAR(((*read)[i].pose - problem.poses[i]).head<2>().norm(), 0.0, 1e-15);
    EXPECT_NEAR(core::WrapAngle((*read)[i].pose.z() - problem.poses[i].z()), 0.0, 1e-14);
  }
}

TEST(TrajectoryMetrics, ReadTumRejectsMalformedLinesWithFileAndLine) {
  ScratchDir dir;
  const std::string header = "# timestamp x y z qx qy qz qw\n";
  const std::string good = "0.5 1 2 0 0 0 0 1\n";
  struct Case {
    std::string contents;
    std::string expected;
  };
  const Case cases[] = {
      {header + good + "1.0 1 2 0 0 0 1\n", ":3: TUM pose has 7 fields; expected 8"},
      {header + good + "\n" + "1.0 1 abc 0 0 0 0 1\n", ":4: TUM pose field 3 (position) is 'abc'"},
      {good + "1.0 1 2 0 0 0 0 nan\n", ":2: TUM pose field 8 (quaternion)"},
      {good + "1.0 1 2 0 0 0 0 0\n", ":2: quaternion (qx qy qz qw) has norm 0"},
  };
  for (const Case& c : cases) {
    const std::string path = dir.File("bad.tum", c.contents);
    const Status status = ReadTum(path).status();
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_NE(status.message().find("bad.tum" + c.expected), std::string::npos)
        << status.message() << "\nexpected: bad.tum" << c.expected;
  }
  EXPECT_TRUE(ReadTum(dir.Path("missing.tum")).status().IsNotFound());
  // Yaw of a non-normalized quaternion: q = 2 (0, 0, sin 0.5, cos 0.5) -> theta = 1.
  const std::string scaled =
      dir.File("scaled.tum", "3 0 0 7 0 0 " + std::to_string(2 * std::sin(0.5)) + " " +
                                 std::to_string(2 * std::cos(0.5)) + "\n");
  StatusOr<std::vector<StampedPose2>> read = ReadTum(scaled);
  ASSERT_TRUE(read.ok());
  EXPECT_NEAR((*read)[0].pose.z(), 1.0, 1e-6);
}

TEST(TrajectoryMetrics, ReadFeaturesCsvReadsTheWriterOutputAndSkipsExcluded) {
  ScratchDir dir;
  core::Problem2d problem;
  problem.AddPose(0, core::Pose2::Zero(), true, 0);
  problem.AddFeature(1000000, core::Point2(1.5, -2.25), true);
  problem.AddFeature(1000001, core::Point2(3, 4), true);
  problem.AddFeature(1000002, core::Point2(-7, 0.125), true);
  const std::vector<uint8_t> excluded = {0, 1, 0};
  const std::string path = dir.Path("f.csv");
  ASSERT_TRUE(storage::WriteFeaturesCsv(problem, path, &excluded).ok());
  std::vector<int64_t> excluded_ids;
  StatusOr<std::map<int64_t, core::Point2>> read = ReadFeaturesCsv(path, &excluded_ids);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->size(), 2u);
  EXPECT_EQ(read->at(1000000), core::Point2(1.5, -2.25));
  EXPECT_EQ(read->at(1000002), core::Point2(-7, 0.125));
  EXPECT_EQ(excluded_ids, std::vector<int64_t>{1000001});

  // Minimal rows without header or the optional columns.
  StatusOr<std::map<int64_t, core::Point2>> minimal =
      ReadFeaturesCsv(dir.File("m.csv", "6, 1.0, 2.0\n# comment\n7,3,4\n"));
  ASSERT_TRUE(minimal.ok()) << minimal.status().ToString();
  EXPECT_EQ(minimal->size(), 2u);
}

TEST(TrajectoryMetrics, ReadFeaturesCsvRejectsMalformedLinesWithFileAndLine) {
  ScratchDir dir;
  const std::string header = "id,x,y,observations,excluded\n";
  struct Case {
    std::string contents;
    std::string expected;
  };
  const Case cases[] = {
      {header + "1,2,3,4,0\n5,6\n", ":3: expected at least 3 fields"},
      {header + "x1,2,3,4,0\n", ":2: id: expected an integer, got 'x1'"},
      {header + "1,2,inf,4,0\n", ":2: y: expected a finite number, got 'inf'"},
      {header + "1,2,3,4,2\n", ":2: excluded: expected 0 or 1, got '2'"},
      {header + "1,2,3,4,0\n\n1,5,6,4,0\n", ":4: duplicate feature id 1 (first on line 2)"},
  };
  for (const Case& c : cases) {
    const std::string path = dir.File("bad.csv", c.contents);
    const Status status = ReadFeaturesCsv(path).status();
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_NE(status.message().find(path + c.expected), std::string::npos)
        << status.message() << "\nexpected: " << path + c.expected;
  }
  EXPECT_TRUE(ReadFeaturesCsv(dir.Path("missing.csv")).status().IsNotFound());
}

}  // namespace
}  // namespace graphslam::tools
