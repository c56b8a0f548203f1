#include "storage/mrclam_reader.h"

#include "core/unidentified_features.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <unistd.h>

#include <Eigen/LU>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "tests/testing/datasets.h"

namespace graphslam::storage {
namespace {

using testing::DatasetPath;

constexpr const char* kFolder = "mrclam_dataset1_sampled50hz";

TEST(MrclamReader, Robot1CountsAndRobotBarcodeFiltering) {
  GS_REQUIRE_DATASET(kFolder);
  MrclamReadStats stats;
  MrclamOptions every;  // every reading its own observation
  every.merge_standstill_repeats = false;
  const auto problem = ReadMrclam(DatasetPath(kFolder), every, &stats);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->num_poses(), 75000);
  EXPECT_EQ(problem->motions.size(), 74999u);
  EXPECT_EQ(stats.odometry_records, 75000);
  EXPECT_EQ(stats.measurements, 5723);
  // Robot 1 sees robots 2..5 (barcodes 14, 41, 32, 23): 226 + 239 + 269 + 218.
  EXPECT_EQ(stats.robot_measurements_dropped, 952);
  EXPECT_EQ(stats.out_of_time_range_dropped, 0);
  EXPECT_EQ(stats.landmark_observations, 4771);
  EXPECT_EQ(problem->observations.size(), 4771u);
  EXPECT_EQ(problem->num_features(), 15);
  for (int64_t id : problem->feature_ids) {
    EXPECT_GE(id, 6);
    EXPECT_LE(id, 20);
  }
  // First landmark measurement "12.72 90 2.148 0.025": barcode 90 = subject 16,
  // attached to the pose at t = 12.72 (index 636 on the 0.02 s grid).
  const core::Observation& first = problem->observations[0];
  EXPECT_EQ(problem->feature_ids[first.feature], 16);
  EXPECT_EQ(first.pose, 636);
  EXPECT_DOUBLE_EQ(problem->pose_stamps[first.pose], 12.72);
  EXPECT_EQ(first.kind, core::ObservationKind::kRangeBearing);
  EXPECT_EQ(first.z, Eigen::Vector2d(2.148, 0.025));
  // 1 / (0.1^2 + (0.04 * 2.148)^2): the range noise grows with the range.
  EXPECT_NEAR(first.information(0, 0), 1.0 / (0.01 + 0.04 * 0.04 * 2.148 * 2.148), 1e-9);
  EXPECT_NEAR(first.information(1, 1), 400.0, 1e-9);
  EXPECT_NEAR(first.information(0, 1), 0.0, 1e-12);
  // Pose 0: first ground-truth pose, fixed; the rest uninitialized.
  EXPECT_EQ(problem->poses[0], core::Pose2(3.5732, -3.3328, 2.3408));
  EXPECT_EQ(problem->pose_fixed[0], 1);
  EXPECT_EQ(problem->pose_initialized[0], 1);
  EXPECT_EQ(problem->pose_initialized[1], 0);
  // Motion k: dt from the stamps, information = covariance^-1.
  const core::VelocityMotionConstraint& motion = problem->motions[10];
  EXPECT_EQ(motion.from, 10);
  EXPECT_EQ(motion.to, 11);
  EXPECT_NEAR(motion.control.dt, 0.02, 1e-12);
  const Eigen::Matrix3d covariance = core::VelocityMotionCovariance(
      problem->poses[10], motion.control, MrclamOptions().noise);
  EXPECT_TRUE((motion.information * covariance).isIdentity(1e-9));
}

TEST(MrclamReader, IgnoredBarcodesKeepTheObservationsWithoutIds) {
  GS_REQUIRE_DATASET(kFolder);
  MrclamOptions every;  // every reading its own observation, as without barcodes
  every.merge_standstill_repeats = false;
  const auto known = ReadMrclam(DatasetPath(kFolder), every);
  ASSERT_TRUE(known.ok()) << known.status().ToString();
  MrclamOptions options;
  options.ignore_barcodes = true;
  const auto unknown = ReadMrclam(DatasetPath(kFolder), options);
  ASSERT_TRUE(unknown.ok()) << unknown.status().ToString();
  ASSERT_EQ(unknown->observations.size(), known->observations.size());
  EXPECT_EQ(core::CountUnidentifiedObservations(*unknown).count,
            static_cast<int64_t>(unknown->observations.size()));
  EXPECT_EQ(unknown->num_features(), static_cast<int32_t>(unknown->observations.size()));
  for (size_t i = 0; i < unknown->observations.size(); ++i) {
    ASSERT_EQ(unknown->observations[i].pose, known->observations[i].pose);
    ASSERT_EQ(unknown->observations[i].z, known->observations[i].z);
    ASSERT_EQ(unknown->feature_ids[unknown->observations[i].feature], core::kNoFeatureId);
  }
}

TEST(MrclamReader, DurationReadsThePrefixOfTheLog) {
  GS_REQUIRE_DATASET(kFolder);
  // Every reading its own observation, so the two reads pair up one to one.
  MrclamOptions options;
  options.merge_standstill_repeats = false;
  const auto full = ReadMrclam(DatasetPath(kFolder), options);
  ASSERT_TRUE(full.ok()) << full.status().ToString();
  options.duration = 200.0;
  MrclamReadStats stats;
  const auto slice = ReadMrclam(DatasetPath(kFolder), options, &stats);
  ASSERT_TRUE(slice.ok()) << slice.status().ToString();
  // 50 Hz: the poses of [t_0, t_0 + 200 s].
  EXPECT_EQ(slice->num_poses(), 10001);
  EXPECT_LE(slice->pose_stamps.back() - slice->pose_stamps.front(), 200.0);
  EXPECT_EQ(slice->motions.size(), 10000u);
  ASSERT_GT(slice->observations.size(), 100u);
  ASSERT_LT(slice->observations.size(), full->observations.size());
  EXPECT_GT(stats.out_of_time_range_dropped, 0);
  // The same observations on the same poses, except that a measurement just
  // after the end goes to the last pose (within max_time_offset).
  for (size_t i = 0; i < slice->observations.size(); ++i) {
    const int32_t pose = full->observations[i].pose;
    ASSERT_EQ(slice->observations[i].pose, std::min(pose, slice->num_poses() - 1));
    ASSERT_EQ(slice->observations[i].z, full->observations[i].z);
  }
  options.duration = -1.0;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
}

TEST(MrclamReader, GroundTruth) {
  GS_REQUIRE_DATASET(kFolder);
  const auto truth = ReadMrclamGroundTruth(DatasetPath(kFolder), 1);
  ASSERT_TRUE(truth.ok()) << truth.status().ToString();
  EXPECT_EQ(truth->stamps.size(), 75000u);
  EXPECT_EQ(truth->poses.size(), 75000u);
  ASSERT_EQ(truth->landmarks.size(), 15u);
  EXPECT_EQ(truth->landmarks.begin()->first, 6);
  EXPECT_EQ(truth->landmarks.at(6), core::Point2(5.70928255, 4.96404466));
}

TEST(MrclamReader, OptionsAreValidated) {
  MrclamOptions options;
  options.robot = 7;
  EXPECT_EQ(options.Validate().message(), "MrclamOptions.robot is 7; expected 1..5");
  options = MrclamOptions();
  options.measurement_information(1, 1) = -1.0;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  options = MrclamOptions();
  options.range_sigma_per_meter = -0.1;
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  options = MrclamOptions();
  options.noise.noise_time_constant = -0.5;
  EXPECT_EQ(options.Validate().message(),
            "MrclamOptions.noise.noise_time_constant is -0.5; expected a finite number of "
            "seconds >= 0 (0: per step)");
  options.noise.noise_time_constant = std::nan("");
  EXPECT_TRUE(options.Validate().IsInvalidArgument());
  EXPECT_TRUE(ReadMrclam("/nonexistent", MrclamOptions()).status().IsNotFound());
}

class MrclamSmallTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = (std::filesystem::temp_directory_path() /
            ("graphslam_mrclam_" + std::to_string(::getpid())))
               .string();
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    Write("Barcodes.dat", "# header\n# Subject # Barcode #\n 1 5\n 2 14\n 6 72\n 7 27\n");
    // Irregular (raw-like) time stamps, with header lines.
    Write("Robot1_Odometry.dat", "# Time [s] v [m/s] w [rad/s]\n"
                                 "100.0 0.1 0.0\n100.013 0.1 0.2\n100.041 0.0 0.0\n");
    Write("Robot1_Measurement.dat", "# header\n100.02 72 1.5 0.1\n100.02 14 2.0 0.0\n"
                                    "100.04 27 3.0 -0.1\n200.0 72 1.0 0.0\n");
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  void Write(const std::string& name, const std::string& contents) {
    std::ofstream(dir_ + "/" + name) << contents;
  }
  std::string dir_;
};

TEST_F(MrclamSmallTest, RawIrregularStampsWithoutGroundTruth) {
  MrclamReadStats stats;
  const auto problem = ReadMrclam(dir_, MrclamOptions(), &stats);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->num_poses(), 3);
  EXPECT_EQ(problem->poses[0], core::Pose2::Zero());  // no ground truth: origin
  ASSERT_EQ(problem->motions.size(), 2u);
  EXPECT_NEAR(problem->motions[0].control.dt, 0.013, 1e-12);
  EXPECT_NEAR(problem->motions[1].control.dt, 0.028, 1e-12);
  EXPECT_EQ(problem->motions[0].line, 2);
  EXPECT_EQ(stats.robot_measurements_dropped, 1);
  EXPECT_EQ(stats.out_of_time_range_dropped, 1);
  ASSERT_EQ(problem->observations.size(), 2u);
  EXPECT_EQ(problem->observations[0].pose, 1);  // 100.02 is nearest to 100.013
  EXPECT_EQ(problem->observations[1].pose, 2);
  EXPECT_EQ(problem->feature_ids[problem->observations[1].feature], 7);
  EXPECT_EQ(problem->observations[1].line, 4);
}

// The summed heading variance of the motion steps over 2 s of one turning
// control, as the reader's information gives it.
double HeadingVarianceOver2s(const std::string& dir, int hz, const MrclamOptions& options) {
  std::ofstream odometry(dir + "/Robot1_Odometry.dat");
  for (int k = 0; k <= 2 * hz; ++k) odometry << 100.0 + k / static_cast<double>(hz) << " 0.3 0.4\n";
  odometry.close();
  const auto problem = ReadMrclam(dir, options);
  EXPECT_TRUE(problem.ok()) << problem.status().ToString();
  if (!problem.ok()) return 0.0;
  double variance = 0.0;
  for (const core::VelocityMotionConstraint& m : problem->motions) {
    variance += m.information.inverse()(2, 2);
  }
  return variance;
}

// The same drive logged at 25 Hz and at 250 Hz: with the reader's default
// noise (per unit time) the heading variance accumulated over the drive is
// the same; with the per-step model it is ten times smaller at 250 Hz.
TEST_F(MrclamSmallTest, DefaultMotionNoiseDoesNotDependOnTheLoggingRate) {
  const MrclamOptions defaults;
  ASSERT_GT(defaults.noise.noise_time_constant, 0.0);
  const double slow = HeadingVarianceOver2s(dir_, 25, defaults);
  const double fast = HeadingVarianceOver2s(dir_, 250, defaults);
  EXPECT_NEAR(fast / slow, 1.0, 1e-6);
  MrclamOptions per_step;
  per_step.noise.noise_time_constant = 0.0;
  const double ratio = HeadingVarianceOver2s(dir_, 250, per_step) /
                       HeadingVarianceOver2s(dir_, 25, per_step);
  EXPECT_LT(ratio, 0.5);
}

TEST_F(MrclamSmallTest, UnknownBarcodesAreSkippedCountedAndListed) {
  // Barcodes 99 and 43 are in no row of Barcodes.dat; 7 of them, of which the
  // first five lines are kept; the known records around them are read.
  Write("Robot1_Measurement.dat",
        "# header\n100.02 99 1.5 0.1\n100.02 72 1.5 0.1\n100.02 43 2.5 -0.2\n"
        "100.04 99 1 0\n100.04 99 1 0\n100.04 99 1 0\n100.04 99 1 0\n100.04 99 1 0\n"
        "100.04 27 3.0 -0.1\n");
  MrclamReadStats stats;
  const auto problem = ReadMrclam(dir_, MrclamOptions(), &stats);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(stats.measurements, 9);
  EXPECT_EQ(stats.unknown_barcodes_skipped, 7);
  EXPECT_EQ(stats.landmark_observations, 2);
  ASSERT_EQ(problem->observations.size(), 2u);
  EXPECT_EQ(problem->feature_ids[problem->observations[0].feature], 6);
  EXPECT_EQ(problem->feature_ids[problem->observations[1].feature], 7);
  EXPECT_EQ(problem->observations[1].line, 10);
  ASSERT_EQ(stats.unknown_barcode_lines.size(), MrclamReadStats::kMaxUnknownBarcodeLines);
  EXPECT_EQ(stats.unknown_barcode_lines[0], "Robot1_Measurement.dat:2: 100.02 99 1.5 0.1");
  EXPECT_EQ(stats.unknown_barcode_lines[1], "Robot1_Measurement.dat:4: 100.02 43 2.5 -0.2");
  EXPECT_EQ(stats.unknown_barcode_lines[4], "Robot1_Measurement.dat:7: 100.04 99 1 0");
}

// Poses 0-2 stand still (controls 0, 1 are zero), control 2 moves, poses 3-4
// stand still again: readings of one landmark within a standstill become one
// observation at the first reading's pose, z = the mean (circular in the
// bearing), with the information of one reading.
TEST_F(MrclamSmallTest, StandstillRepeatsOfALandmarkBecomeOneObservation) {
  Write("Robot1_Odometry.dat", "0 0 0\n0.02 0 0\n0.04 0.1 0\n0.06 0 0\n0.08 0 0\n");
  Write("Robot1_Measurement.dat",
        "0 72 1.0 0.1\n0.02 72 1.2 0.3\n0.02 27 2.0 0.0\n0.04 72 1.4 0.2\n"
        "0.06 72 1.0 3.1\n0.08 72 3.0 -3.1\n");
  MrclamReadStats stats;
  const auto merged = ReadMrclam(dir_, MrclamOptions(), &stats);
  ASSERT_TRUE(merged.ok()) << merged.status().ToString();
  EXPECT_EQ(stats.standstill_repeats_merged, 3);
  EXPECT_EQ(stats.landmark_observations, 3);
  EXPECT_EQ(stats.landmark_observations + stats.standstill_repeats_merged, stats.measurements);
  ASSERT_EQ(merged->observations.size(), 3u);
  const core::Observation& first = merged->observations[0];
  EXPECT_EQ(merged->feature_ids[first.feature], 6);
  EXPECT_EQ(first.pose, 0);
  EXPECT_EQ(first.line, 1);
  EXPECT_NEAR(first.z.x(), 1.2, 1e-12);
  EXPECT_NEAR(first.z.y(), 0.2, 1e-12);
  // One reading's information at the mean range.
  const double sigma2 = 0.1 * 0.1 + 0.04 * 0.04 * 1.2 * 1.2;
  EXPECT_TRUE(first.information.isApprox(Eigen::Vector2d(1.0 / sigma2, 400.0).asDiagonal().toDenseMatrix(), 1e-9));
  EXPECT_EQ(merged->feature_ids[merged->observations[1].feature], 7);  // another landmark
  EXPECT_EQ(merged->observations[1].z, Eigen::Vector2d(2.0, 0.0));
  // After the robot moved: a new standstill, a new observation; 3.1 and -3.1
  // average to pi, not to 0.
  const core::Observation& after = merged->observations[2];
  EXPECT_EQ(after.pose, 3);
  EXPECT_NEAR(after.z.x(), 2.0, 1e-12);
  EXPECT_NEAR(std::abs(after.z.y()), M_PI, 1e-12);

  MrclamOptions every;
  every.merge_standstill_repeats = false;
  const auto unmerged = ReadMrclam(dir_, every, &stats);
  ASSERT_TRUE(unmerged.ok()) << unmerged.status().ToString();
  EXPECT_EQ(stats.standstill_repeats_merged, 0);
  EXPECT_EQ(unmerged->observations.size(), 6u);
  // Unknown correspondence: the barcodes may not group readings.
  MrclamOptions unknown;
  unknown.ignore_barcodes = true;
  const auto unidentified = ReadMrclam(dir_, unknown);
  ASSERT_TRUE(unidentified.ok()) << unidentified.status().ToString();
  EXPECT_EQ(unidentified->observations.size(), 6u);
}

TEST_F(MrclamSmallTest, RobotSightingsAreKeptBesideTheProblem) {
  MrclamReadStats stats;
  const auto problem = ReadMrclam(dir_, MrclamOptions(), &stats);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  // "100.02 14 2.0 0.0": barcode 14 is robot 2.
  ASSERT_EQ(stats.robot_sightings.size(), 1u);
  EXPECT_EQ(stats.robot_sightings[0].stamp, 100.02);
  EXPECT_EQ(stats.robot_sightings[0].observed_robot, 2);
  EXPECT_EQ(stats.robot_sightings[0].z, Eigen::Vector2d(2.0, 0.0));
  EXPECT_EQ(stats.robot_sightings[0].line, 3);
}

// The published dataset 1 (all five robots) has barcode 43, in no row of
// Barcodes.dat, in robots 3 (twice) and 5 (once): every robot reads.
TEST(MrclamReader, Dataset1AllRobotsReadWithTheirMisreadBarcodesSkipped) {
  GS_REQUIRE_DATASET(kFolder);
  const int64_t expected_unknown[5] = {0, 0, 2, 0, 1};
  const int64_t expected_sightings[5] = {952, 1156, 1969, 722, 1654};
  for (int robot = 1; robot <= 5; ++robot) {
    MrclamOptions options;
    options.robot = robot;
    MrclamReadStats stats;
    const auto problem = ReadMrclam(DatasetPath(kFolder), options, &stats);
    ASSERT_TRUE(problem.ok()) << "robot " << robot << ": " << problem.status().ToString();
    EXPECT_EQ(stats.unknown_barcodes_skipped, expected_unknown[robot - 1]) << robot;
    EXPECT_EQ(static_cast<int64_t>(stats.robot_sightings.size()), expected_sightings[robot - 1])
        << robot;
    EXPECT_EQ(stats.landmark_observations + stats.standstill_repeats_merged +
                  stats.robot_measurements_dropped + stats.unknown_barcodes_skipped +
                  stats.out_of_time_range_dropped,
              stats.measurements)
        << robot;
  }
  MrclamOptions options;
  options.robot = 3;
  MrclamReadStats stats;
  ASSERT_TRUE(ReadMrclam(DatasetPath(kFolder), options, &stats).ok());
  ASSERT_EQ(stats.unknown_barcode_lines.size(), 2u);
  EXPECT_EQ(stats.unknown_barcode_lines[0], "Robot3_Measurement.dat:4938: 942.52 43 1.992 -0.287");
  EXPECT_EQ(stats.unknown_barcode_lines[1], "Robot3_Measurement.dat:4943: 943.22 43 1.953 -0.293");
  // Without the ground-truth start the robot starts at the origin.
  options.start_at_ground_truth = false;
  const auto origin = ReadMrclam(DatasetPath(kFolder), options);
  ASSERT_TRUE(origin.ok());
  EXPECT_EQ(origin->poses[0], core::Pose2::Zero());
}

TEST_F(MrclamSmallTest, RejectsMalformedRecords) {
  Write("Robot1_Measurement.dat", "100.02 72 1.5\n");
  EXPECT_EQ(ReadMrclam(dir_, MrclamOptions()).status().message(),
            "Robot1_Measurement.dat:1: measurement has 3 fields; expected 4 (t barcode range "
            "bearing)");
  Write("Robot1_Odometry.dat", "100.0 0.1 0.0\n99.0 0.1 nan\n");
  EXPECT_EQ(ReadMrclam(dir_, MrclamOptions()).status().message(),
            "Robot1_Odometry.dat:2: record field 3 (value) is 'nan'; expected a finite number");
  Write("Robot1_Odometry.dat", "100.0 0.1 0.0\n99.0 0.1 0\n");
  EXPECT_EQ(ReadMrclam(dir_, MrclamOptions()).status().message(),
            "Robot1_Odometry.dat:2: time 99 is earlier than the previous record's 100; expected "
            "non-decreasing time stamps");
}

}  // namespace
}  // namespace graphslam::storage
