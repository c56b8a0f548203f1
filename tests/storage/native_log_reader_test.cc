#include "storage/native_log_reader.h"

#include "core/unidentified_features.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <unistd.h>

#include <Eigen/LU>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace graphslam::storage {
namespace {

std::string TempPath(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("graphslam_native_log_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return (dir / name).string();
}

std::string WriteTemp(const std::string& name, const std::string& contents) {
  const std::string path = TempPath(name);
  std::ofstream(path) << contents;
  return path;
}

Status ReadError(const std::string& contents, const std::string& name = "bad.log") {
  const auto problem = ReadNativeLog(WriteTemp(name, contents));
  EXPECT_FALSE(problem.ok());
  return problem.ok() ? Status::Ok() : problem.status();
}

constexpr const char* kExample =
    "GRAPHSLAM_LOG 1\n"
    "# two poses, a control, a landmark seen twice\n"
    "POSE 0 0.0 0 0 0\n"
    "FIX 0\n"
    "POSE 1 0.5\n"
    "CONTROL 0 1 1.0 0.1 0.5\n"
    "POSE 2 -\n"
    "CONTROL_INFO 1 2 1.0 0.1 0.5 1e4 0 0 1e4 0 1e4\n"
    "ODOM 0 2 1 0 0.1 100 0 0 100 0 100\n"
    "FEATURE 3 5 1\n"
    "RB 0 7 5.2 0.3 100 0 400\n"
    "XY 1 3 4.8 0.33 100 0 400\n"
    "GPS 2 1.0 0.1 4 0 4\n"
    "RB_POSE 1 2 3.5 -0.2 100 0 400\n";

// The per-feature arrays of two reads of one log are equal.
void ExpectSameFeatures(const core::Problem2d& read, const core::Problem2d& expected) {
  EXPECT_EQ(read.feature_ids, expected.feature_ids);
  EXPECT_EQ(read.feature_initialized, expected.feature_initialized);
  ASSERT_EQ(read.features.size(), expected.features.size());
  for (size_t f = 0; f < read.features.size(); ++f)
    EXPECT_EQ(read.features[f], expected.features[f]) << "feature " << f;
}

TEST(NativeLogReader, ReadsEveryRecordOfTheSpecExample) {
  const auto problem = ReadNativeLog(WriteTemp("example.log", kExample));
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  ASSERT_EQ(problem->num_poses(), 3);
  EXPECT_EQ(problem->pose_fixed[0], 1);
  EXPECT_EQ(problem->pose_initialized[1], 0);
  EXPECT_DOUBLE_EQ(problem->pose_stamps[1], 0.5);
  EXPECT_TRUE(std::isnan(problem->pose_stamps[2]));
  ASSERT_EQ(problem->motions.size(), 2u);
  // CONTROL: Omega = R^-1 at pose 0's guess, with the default noise.
  const core::VelocityControl control{1.0, 0.1, 0.5};
  const Eigen::Matrix3d expected =
      core::VelocityMotionCovariance(core::Pose2::Zero(), control, core::VelocityNoise())
          .inverse();
  EXPECT_TRUE(problem->motions[0].information.isApprox(expected, 1e-12));
  // Pose 1's value is the dead-reckoned hint (spec rule 3).
  EXPECT_TRUE(problem->poses[1].isApprox(core::PredictVelocityMotion(core::Pose2::Zero(), control)));
  EXPECT_EQ(problem->motions[1].information, Eigen::Matrix3d::Identity() * 1e4);
  ASSERT_EQ(problem->relative_poses.size(), 1u);
  EXPECT_EQ(problem->relative_poses[0].line, 9);
  ASSERT_EQ(problem->num_features(), 2);
  EXPECT_EQ(problem->feature_ids[0], 3);
  EXPECT_EQ(problem->feature_initialized[0], 1);
  EXPECT_EQ(problem->feature_ids[1], 7);  // implicit at first use
  EXPECT_EQ(problem->feature_initialized[1], 0);
  ASSERT_EQ(problem->observations.size(), 2u);
  EXPECT_EQ(problem->observations[0].kind, core::ObservationKind::kRangeBearing);
  EXPECT_EQ(problem->observations[1].kind, core::ObservationKind::kPointXY);
  ASSERT_EQ(problem->gps.size(), 1u);
  EXPECT_EQ(problem->gps[0].pose, 2);
  ASSERT_EQ(problem->pose_range_bearings.size(), 1u);
  EXPECT_EQ(problem->pose_range_bearings[0].from, 1);
  EXPECT_EQ(problem->pose_range_bearings[0].to, 2);
  EXPECT_EQ(problem->pose_range_bearings[0].z, Eigen::Vector2d(3.5, -0.2));
  EXPECT_EQ(problem->pose_range_bearings[0].information,
            Eigen::Matrix2d(Eigen::Vector2d(100.0, 400.0).asDiagonal()));
  EXPECT_EQ(problem->pose_range_bearings[0].line, 14);
}

// ReadNativeLogWithoutFeatures (an MPI rank's read of a chunk store's
// problem): the poses and pose-only factors of ReadNativeLog, no feature; a
// FEATURE record is still checked.
// Expected sizes (a counts trailer's) only reserve: right, too small, too
// large or absurd, the streamed read gives the same problem and observations.
TEST(NativeLogReader, ExpectedSizesChangeNothingButWhatIsReserved) {
  const std::string path = WriteTemp("expected.log", kExample);
  const auto read = [&](const ExpectedSizes& expected, std::vector<core::Observation>* seen) {
    return ReadNativeLogStreaming(
        path, [seen](const core::Observation& o) { seen->push_back(o); return Status::Ok(); },
        nullptr, expected);
  };
  std::vector<core::Observation> plain_seen;
  const auto plain = read({}, &plain_seen);
  ASSERT_TRUE(plain.ok()) << plain.status().ToString();
  ASSERT_EQ(plain->num_features(), 2);
  for (const ExpectedSizes expected : {ExpectedSizes{2, 8}, ExpectedSizes{1, 4},
                                       ExpectedSizes{1000, 1000000}, ExpectedSizes{-5, -1},
                                       ExpectedSizes{int64_t{1} << 40, int64_t{1} << 40}}) {
    std::vector<core::Observation> seen;
    const auto problem = read(expected, &seen);
    ASSERT_TRUE(problem.ok()) << problem.status().ToString();
    ExpectSameFeatures(*problem, *plain);
    ASSERT_EQ(seen.size(), plain_seen.size());
    for (size_t i = 0; i < seen.size(); ++i) {
      EXPECT_EQ(seen[i].pose, plain_seen[i].pose);
      EXPECT_EQ(seen[i].feature, plain_seen[i].feature);
      EXPECT_EQ(seen[i].z, plain_seen[i].z);
    }
  }
}

// A log whose features mostly come by their first use (no guess held while
// it is read) with one FEATURE guess late (from there on they are): the
// guesses, flags and ids are those of a read that holds them all along, and
// with size_guesses false the caller gets them unsized and sizes them.
TEST(NativeLogReader, GuessesAreSizedAfterTheReadOrFromTheFirstFeatureGuess) {
  std::string log = "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\nPOSE 1 1 1 0 0\n";
  for (int f = 0; f < 150; ++f) log += "RB 0 " + std::to_string(1000 + 3 * f) + " 5 0.1 1 0 1\n";
  const std::string unguessed = log + "RB 1 - 4 0.2 1 0 1\n";
  const std::string guessed = unguessed + "FEATURE 77 2.5 -1\nRB 1 77 3 0 1 0 1\nFEATURE 78\n";
  for (const std::string& contents : {unguessed, guessed}) {
    const std::string path = WriteTemp("guesses.log", contents);
    const auto all = ReadNativeLog(path);
    ASSERT_TRUE(all.ok()) << all.status().ToString();
    const ObservationSink ignore = [](const core::Observation&) { return Status::Ok(); };
    for (const bool size_guesses : {true, false}) {
      auto streamed = ReadNativeLogStreaming(path, ignore, nullptr, {}, size_guesses);
      ASSERT_TRUE(streamed.ok()) << streamed.status().ToString();
      EXPECT_EQ(streamed->feature_ids, all->feature_ids);
      // Unsized only when no FEATURE record gave a guess.
      EXPECT_EQ(streamed->features.empty(), !size_guesses && contents == unguessed);
      SizeGuesses(&*streamed);
      EXPECT_EQ(streamed->feature_initialized, all->feature_initialized);
      ASSERT_EQ(streamed->features.size(), all->features.size());
      for (size_t f = 0; f < all->features.size(); ++f)
        EXPECT_EQ(streamed->features[f], all->features[f]) << f;
    }
  }
  const auto read = ReadNativeLog(WriteTemp("guesses.log", guessed));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->num_features(), 153);
  EXPECT_EQ(read->feature_ids[150], core::kNoFeatureId);
  EXPECT_EQ(read->feature_initialized[151], 1);
  EXPECT_EQ(read->features[151], core::Point2(2.5, -1));
  EXPECT_EQ(read->feature_initialized[152], 0);
  EXPECT_EQ(read->feature_initialized[149], 0);
}

// The FEATURE-record rules name the line of the earlier declaration or first
// use, kept compactly (storage/internal/monotone_lines.h) for every feature,
// here the 130th of 150 (past two groups of 64) and after a long gap.
TEST(NativeLogReader, FeatureRuleMessagesNameTheEarlierLineOfAnyFeature) {
  std::string log = "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\n";
  for (int f = 0; f < 150; ++f) {
    log += f % 2 == 0 ? "FEATURE " + std::to_string(f) + "\n"
                      : "RB 0 " + std::to_string(f) + " 5 0.1 1 0 1\n";
    if (f == 100)
      for (int k = 0; k < 300; ++k) log += "POSE " + std::to_string(1 + k) + " 1\n";
  }
  // Feature 130 (declared) is on line 2 + 130 + 300 + 1; 131 (used) the next.
  EXPECT_EQ(ReadError(log + "FEATURE 130\n").message(),
            "bad.log:453: FEATURE 130 is already declared at line 433; expected one FEATURE "
            "record, before the feature's first use");
  EXPECT_EQ(ReadError(log + "FEATURE 131\n").message(),
            "bad.log:453: FEATURE 131 comes after its first use at line 434; expected one FEATURE "
            "record, before the feature's first use");
  EXPECT_EQ(ReadError(log + "FEATURE 3\n").message(),
            "bad.log:453: FEATURE 3 comes after its first use at line 6; expected one FEATURE "
            "record, before the feature's first use");
}

// The writer's duplicate check takes one bit per id for dense ids and a
// sorted copy otherwise: a repeated feature or pose id is named either way,
// and distinct ids of either kind are written.
TEST(NativeLogReader, WriterRejectsRepeatedIdsDenseOrSparse) {
  const std::string path = TempPath("ids.log");
  const auto problem_with = [](const std::vector<int64_t>& feature_ids,
                               const std::vector<int64_t>& pose_ids) {
    core::Problem2d problem;
    for (size_t i = 0; i < pose_ids.size(); ++i)
      problem.AddPose(pose_ids[i], core::Pose2(static_cast<double>(i), 0, 0), true, 0);
    problem.pose_fixed[0] = 1;
    for (const int64_t id : feature_ids) problem.AddFeature(id, core::Point2(1, 2), true);
    return problem;
  };
  std::vector<int64_t> dense(200), sparse(200), negative(200);
  for (int i = 0; i < 200; ++i) {
    dense[static_cast<size_t>(i)] = 3 * i;
    sparse[static_cast<size_t>(i)] = (int64_t{1} << 40) + int64_t{1000000} * i;
    negative[static_cast<size_t>(i)] = -5 - i;
  }
  const std::vector<int64_t> poses = {0, 1, 2};
  for (std::vector<int64_t> ids : {dense, sparse, negative}) {
    EXPECT_TRUE(WriteNativeLog(problem_with(ids, poses), path).ok());
    const int64_t repeated = ids[150];
    ids[170] = repeated;
    EXPECT_EQ(WriteNativeLog(problem_with(ids, poses), path).message(),
              "writing " + path + ": feature id " + std::to_string(repeated) +
                  " appears twice; expected unique feature ids");
  }
  EXPECT_EQ(WriteNativeLog(problem_with(dense, {0, 1, 0}), path).message(),
            "writing " + path + ": pose id 0 appears twice; expected unique pose ids");
}

TEST(NativeLogReader, WithoutFeaturesKeepsThePosesAndPoseFactorsOnly) {
  const std::string log =
      "GRAPHSLAM_LOG 1\n"
      "POSE 0 0.0 0 0 0\n"
      "FEATURE 3 5 1\n"
      "POSE 1 0.5 1 0 0\n"
      "FEATURE 4\n"
      "ODOM 0 1 1 0 0.1 100 0 0 100 0 100\n"
      "GPS 1 1.0 0.1 4 0 4\n";
  const auto whole = ReadNativeLog(WriteTemp("poses_whole.log", log));
  const auto poses = ReadNativeLogWithoutFeatures(WriteTemp("poses_only.log", log));
  ASSERT_TRUE(whole.ok()) << whole.status().ToString();
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  EXPECT_EQ(whole->num_features(), 2);
  EXPECT_EQ(poses->num_features(), 0);
  EXPECT_TRUE(poses->feature_ids.empty());
  ASSERT_EQ(poses->num_poses(), 2);
  EXPECT_EQ(poses->pose_ids, whole->pose_ids);
  EXPECT_EQ(poses->poses[1].x(), whole->poses[1].x());
  EXPECT_EQ(poses->relative_poses.size(), whole->relative_poses.size());
  EXPECT_EQ(poses->gps.size(), 1u);
  const auto bad = ReadNativeLogWithoutFeatures(
      WriteTemp("poses_bad.log", "GRAPHSLAM_LOG 1\nPOSE 0 0.0 0 0 0\nFEATURE x 1 2\n"));
  EXPECT_FALSE(bad.ok());
}

// ExpectedSizes::declared_once (a chunk store's problem file): the same
// problem as the checked read, with features in record order whether or not
// they carry a guess, and any record that refers to a feature refused (no
// id table to resolve it), naming its line.
TEST(NativeLogReader, DeclaredOnceReadsTheSameProblemAndRefusesReferences) {
  const std::string log =
      "GRAPHSLAM_LOG 1\n"
      "POSE 0 0.0 0 0 0\n"
      "FEATURE 30 5 1\n"
      "POSE 1 0.5 1 0 0\n"
      "FEATURE 4\n"
      "FEATURE 1000000007 -2 3.5\n"
      "ODOM 0 1 1 0 0.1 100 0 0 100 0 100\n"
      "GPS 1 1.0 0.1 4 0 4\n";
  const auto refuse = [](const core::Observation&) { return Status::Corruption("observation"); };
  ExpectedSizes once;
  once.declared_once = true;
  for (const int64_t features : {int64_t{0}, int64_t{3}, int64_t{1000}}) {
    once.features = features;
    const auto checked = ReadNativeLog(WriteTemp("once_checked.log", log));
    const auto read = ReadNativeLogStreaming(WriteTemp("once.log", log), refuse, nullptr, once);
    ASSERT_TRUE(checked.ok()) << checked.status().ToString();
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    ExpectSameFeatures(*read, *checked);
    EXPECT_EQ(read->pose_ids, checked->pose_ids);
    EXPECT_EQ(read->relative_poses.size(), checked->relative_poses.size());
    EXPECT_EQ(read->gps.size(), checked->gps.size());
  }
  const auto referring = ReadNativeLogStreaming(
      WriteTemp("once_rb.log", log + "RB 1 30 5 0.1 1 0 1\n"), refuse, nullptr, once);
  ASSERT_FALSE(referring.ok());
  EXPECT_TRUE(referring.status().IsCorruption()) << referring.status().ToString();
  EXPECT_NE(referring.status().message().find(":9:"), std::string::npos)
      << referring.status().ToString();
}

TEST(NativeLogReader, RoundTripIsExact) {
  const auto original = ReadNativeLog(WriteTemp("original.log", kExample));
  ASSERT_TRUE(original.ok()) << original.status().ToString();
  core::Problem2d problem = *original;
  problem.poses[0] = core::Pose2(0.1, 1.0 / 3.0, -2.9);  // needs all 17 digits
  const std::string path = TempPath("round_trip.log");
  ASSERT_TRUE(WriteNativeLog(problem, path).ok());
  const auto back = ReadNativeLog(path);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_EQ(back->num_poses(), problem.num_poses());
  EXPECT_EQ(back->pose_ids, problem.pose_ids);
  EXPECT_EQ(back->pose_fixed, problem.pose_fixed);
  EXPECT_EQ(back->pose_initialized, problem.pose_initialized);
  EXPECT_EQ(back->poses[0], problem.poses[0]);  // bit-exact
  EXPECT_EQ(back->pose_stamps[1], problem.pose_stamps[1]);
  EXPECT_TRUE(std::isnan(back->pose_stamps[2]));
  EXPECT_EQ(back->feature_ids, problem.feature_ids);
  EXPECT_EQ(back->features[0], problem.features[0]);
  ASSERT_EQ(back->motions.size(), problem.motions.size());
  for (size_t k = 0; k < problem.motions.size(); ++k) {
    EXPECT_EQ(back->motions[k].information, problem.motions[k].information);
    EXPECT_EQ(back->motions[k].control.dt, problem.motions[k].control.dt);
  }
  ASSERT_EQ(back->observations.size(), problem.observations.size());
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    EXPECT_EQ(back->observations[k].z, problem.observations[k].z);
    EXPECT_EQ(back->observations[k].information, problem.observations[k].information);
    EXPECT_EQ(back->observations[k].kind, problem.observations[k].kind);
  }
  EXPECT_EQ(back->relative_poses[0].z, problem.relative_poses[0].z);
  EXPECT_EQ(back->gps[0].z, problem.gps[0].z);
  ASSERT_EQ(back->pose_range_bearings.size(), 1u);
  EXPECT_EQ(back->pose_range_bearings[0].from, problem.pose_range_bearings[0].from);
  EXPECT_EQ(back->pose_range_bearings[0].to, problem.pose_range_bearings[0].to);
  EXPECT_EQ(back->pose_range_bearings[0].z, problem.pose_range_bearings[0].z);
  EXPECT_EQ(back->pose_range_bearings[0].information,
            problem.pose_range_bearings[0].information);
}

// The writer's lines as docs/formats/native_log.md gives them: the header,
// the provenance comment, then one record a line with single spaces between
// the fields and none before the first.
TEST(NativeLogReader, WrittenLinesHaveTheSpecLayout) {
  const std::string input = WriteTemp("layout_in.log", kExample);
  const auto problem = ReadNativeLog(input);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  const std::string path = TempPath("layout_out.log");
  ASSERT_TRUE(WriteNativeLog(*problem, path).ok());
  std::ifstream in(path);
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  ASSERT_GE(lines.size(), 3u);
  EXPECT_EQ(lines[0], "GRAPHSLAM_LOG " + std::to_string(kNativeLogVersion));
  EXPECT_EQ(lines[1], "# written by graphslam from " + input +
                          " (spec: docs/formats/native_log.md)");
  EXPECT_THAT(lines, ::testing::Contains("FIX 0"));
  for (const std::string& line : lines) {
    ASSERT_FALSE(line.empty());
    EXPECT_NE(line.front(), ' ') << line;
    EXPECT_EQ(line.find("  "), std::string::npos) << line;
  }
  // One line a record (one pose is fixed) after the two header lines.
  const core::Problem2d& p = *problem;
  EXPECT_EQ(lines.size(), 2 + p.poses.size() + p.features.size() + 1 + p.motions.size() +
                              p.relative_poses.size() + p.observations.size() + p.gps.size() +
                              p.pose_range_bearings.size());
}

TEST(NativeLogReader, RejectsBadHeaders) {
  EXPECT_EQ(ReadError("POSE 0 0\n").message(),
            "bad.log:1: first record is 'POSE'; expected the header GRAPHSLAM_LOG 1");
  const Status version = ReadError("# c\nGRAPHSLAM_LOG 2\n");
  EXPECT_TRUE(version.IsNotSupported());
  EXPECT_EQ(version.message(), "bad.log:2: format version 2; expected 1");
  EXPECT_EQ(ReadError("").message(), "bad.log: is empty; expected the header GRAPHSLAM_LOG 1");
}

TEST(NativeLogReader, RejectsMalformedRecords) {
  const std::string header = "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\nPOSE 1 1\n";
  EXPECT_EQ(ReadError(header + "ODOM 0 1 1 0 0 1 0 0 1\n").message(),
            "bad.log:4: ODOM has 10 fields; expected 12");
  EXPECT_EQ(ReadError(header + "ODOM 0 1 1 0 x 1 0 0 1 0 1\n").message(),
            "bad.log:4: ODOM field 6 (measurement) is 'x'; expected a number");
  EXPECT_EQ(ReadError(header + "GPS 1 inf 0 1 0 1\n").message(),
            "bad.log:4: GPS field 3 (position) is 'inf'; expected a finite number");
  EXPECT_EQ(ReadError(header + "XY 1 4 1 1 1 0 0\n").message(),
            "bad.log:4: XY information [1 0 0] is not positive definite; expected a symmetric "
            "positive definite matrix (i11 i12 i22)");
  EXPECT_EQ(ReadError(header + "ODOM 0 77 1 0 0 1 0 0 1 0 1\n").message(),
            "bad.log:4: ODOM refers to pose 77, which no earlier POSE record declares; expected "
            "POSE 77 first");
  EXPECT_EQ(ReadError(header + "POSE 1 2\n").message(),
            "bad.log:4: POSE 1 is already declared at line 3; expected unique pose ids");
  EXPECT_EQ(ReadError(header + "RB 1 4 1 0 1 0 1\nFEATURE 4\n").message(),
            "bad.log:5: FEATURE 4 comes after its first use at line 4; expected one FEATURE "
            "record, before the feature's first use");
  EXPECT_EQ(ReadError(header + "CONTROL 0 1 1 0 -0.1\n").message(),
            "bad.log:4: CONTROL dt is -0.10000000000000001; expected dt >= 0");
  EXPECT_EQ(ReadError(header + "RB 1 4 0 0 1 0 1\n").message(),
            "bad.log:4: RB range is 0; expected range > 0");
  EXPECT_EQ(ReadError(header + "RB_POSE 1 0 0 0 1 0 1\n").message(),
            "bad.log:4: RB_POSE range is 0; expected range > 0");
  EXPECT_EQ(ReadError(header + "RB_POSE 1 1 2 0 1 0 1\n").message(),
            "bad.log:4: RB_POSE connects pose 1 to itself; expected two distinct poses");
  const Status unknown = ReadError(header + "LIDAR 1 2 3\n");
  EXPECT_TRUE(unknown.IsNotSupported());
  // The observation tags come from the model registry, after ODOM.
  EXPECT_THAT(unknown.message(),
              ::testing::StartsWith("bad.log:4: unknown tag 'LIDAR'; expected POSE, FEATURE, "
                                    "CONTROL, CONTROL_INFO, ODOM, RB, XY, "));
  EXPECT_THAT(unknown.message(), ::testing::EndsWith(", RB_POSE, RB_POSE_INTERP, GPS, FIX or SCAN"));
}

// A robot sighting between two poses of the observed robot: read, written and
// read back exactly, and its errors.
TEST(NativeLogReader, InterpolatedRobotSightingRoundTripsAndIsChecked) {
  const std::string header = "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\nPOSE 1 1\nPOSE 2 2\n";
  const auto problem =
      ReadNativeLog(WriteTemp("interp.log", header + "RB_POSE_INTERP 0 1 2 0.25 3.5 -0.2 100 0 400\n"));
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  ASSERT_EQ(problem->pose_range_bearings.size(), 1u);
  const core::PoseRangeBearingConstraint& c = problem->pose_range_bearings[0];
  EXPECT_EQ(c.from, 0);
  EXPECT_EQ(c.to, 1);
  EXPECT_EQ(c.to_next, 2);
  EXPECT_EQ(c.alpha, 0.25);
  EXPECT_EQ(c.z, Eigen::Vector2d(3.5, -0.2));
  EXPECT_EQ(c.information, Eigen::Matrix2d(Eigen::Vector2d(100.0, 400.0).asDiagonal()));
  EXPECT_EQ(c.line, 5);
  core::Problem2d changed = *problem;
  changed.pose_range_bearings[0].alpha = 1.0 / 3.0;  // needs all 17 digits
  const std::string path = TempPath("interp_round_trip.log");
  ASSERT_TRUE(WriteNativeLog(changed, path).ok());
  const auto back = ReadNativeLog(path);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_EQ(back->pose_range_bearings.size(), 1u);
  EXPECT_EQ(back->pose_range_bearings[0].to_next, 2);
  EXPECT_EQ(back->pose_range_bearings[0].alpha, 1.0 / 3.0);
  EXPECT_EQ(back->pose_range_bearings[0].z, c.z);
  EXPECT_EQ(back->pose_range_bearings[0].information, c.information);
  EXPECT_EQ(ReadError(header + "RB_POSE_INTERP 0 1 2 1.5 3.5 -0.2 100 0 400\n").message(),
            "bad.log:5: RB_POSE_INTERP alpha is 1.5; expected 0 <= alpha <= 1");
  EXPECT_EQ(ReadError(header + "RB_POSE_INTERP 0 1 1 0.5 3.5 -0.2 100 0 400\n").message(),
            "bad.log:5: RB_POSE_INTERP pose 1 repeats pose 0 or 1; expected three distinct poses");
  EXPECT_EQ(ReadError(header + "RB_POSE_INTERP 0 1 2 0.5 0 -0.2 100 0 400\n").message(),
            "bad.log:5: RB_POSE_INTERP range is 0; expected range > 0");
  EXPECT_EQ(ReadError(header + "RB_POSE_INTERP 0 1 2 0.5 3.5\n").message(),
            "bad.log:5: RB_POSE_INTERP has 6 fields; expected 10");
}

TEST(NativeLogReader, UnknownCorrespondenceGivesAFeaturePerObservation) {
  const std::string path = WriteTemp(
      "unknown.log",
      "GRAPHSLAM_LOG 1\nPOSE 0 0 0 0 0\nPOSE 1 1\nODOM 0 1 1 0 0 1 0 0 1 0 1\n"
      "RB 0 - 2 0.5 1 0 1\nXY 1 - 1 1 1 0 1\nRB 1 7 2 0 1 0 1\n");
  const auto problem = ReadNativeLog(path);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  const auto unidentified = core::CountUnidentifiedObservations(*problem);
  EXPECT_EQ(unidentified.count, 2);
  EXPECT_EQ(unidentified.first_line, 5);
  ASSERT_EQ(problem->num_features(), 3);
  ASSERT_EQ(problem->observations.size(), 3u);
  EXPECT_EQ(problem->feature_ids[problem->observations[0].feature], core::kNoFeatureId);
  EXPECT_EQ(problem->feature_ids[problem->observations[1].feature], core::kNoFeatureId);
  EXPECT_NE(problem->observations[0].feature, problem->observations[1].feature);
  EXPECT_EQ(problem->feature_ids[problem->observations[2].feature], 7);
  EXPECT_EQ(problem->observations[1].kind, core::ObservationKind::kPointXY);
}


// Information given in the log that is not positive definite: rejected naming
// the file and line, or repaired with the eigenvalue floor and counted.
// ODOM diag(1, 1, -1) -> diag(1, 1, 1e-6); XY [1 2; 2 1] (eigenvalues 3 and
// -1 along (1, 1) and (1, -1)) -> [1.5 + 1.5e-6, 1.5 - 1.5e-6; ...], at
// Frobenius distance 1 + 3e-6; the 1-D B weight -2 -> 2e-6.
TEST(NativeLogReader, RepairsNonPositiveDefiniteInformationOnlyWhenAsked) {
  const std::string path = WriteTemp("indefinite.log",
                                     "GRAPHSLAM_LOG 1\n"
                                     "POSE 0 0 0 0 0\nFIX 0\nPOSE 1 1 1 0 0\nFEATURE 3 5 1\n"
                                     "ODOM 0 1 1 0 0 1 0 0 1 0 -1\n"
                                     "XY 1 3 4 1 1 2 1\n"
                                     "B 0 3 0.3 -2\n");
  const Status rejected = ReadNativeLog(path).status();
  EXPECT_TRUE(rejected.IsCorruption());
  EXPECT_NE(rejected.message().find("indefinite.log:6: ODOM information"), std::string::npos)
      << rejected.message();
  core::InformationRepairs repairs;
  StatusOr<core::Problem2d> problem = ReadNativeLog(path, &repairs);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(repairs.count, 3);
  EXPECT_EQ(repairs.first_lines, (std::vector<int32_t>{6, 7, 8}));
  const Eigen::Matrix3d& odometry = problem->relative_poses[0].information;
  EXPECT_EQ(Eigen::LLT<Eigen::Matrix3d>(odometry).info(), Eigen::Success);
  EXPECT_LT((odometry - Eigen::Vector3d(1, 1, 1e-6).asDiagonal().toDenseMatrix())
                .cwiseAbs()
                .maxCoeff(),
            1e-15)
      << odometry;
  ASSERT_EQ(problem->observations.size(), 2u);
  const Eigen::Matrix2d& xy = problem->observations[0].information;
  EXPECT_EQ(Eigen::LLT<Eigen::Matrix2d>(xy).info(), Eigen::Success);
  Eigen::Matrix2d expected, original;
  expected << 1.5 + 1.5e-6, 1.5 - 1.5e-6, 1.5 - 1.5e-6, 1.5 + 1.5e-6;
  original << 1, 2, 2, 1;
  EXPECT_LT((xy - expected).cwiseAbs().maxCoeff(), 1e-12) << xy;
  EXPECT_NEAR((xy - original).norm(), 1.0 + 3e-6, 1e-12);
  EXPECT_NEAR(problem->observations[1].information(0, 0), 2e-6, 1e-18);
}

// The parallel tokenizer's shortcuts (integers converted while tokenizing and
// taken by the ids, repeated tokens reused, a repeated information not
// factorized again) give what std::from_chars and a factorization per record
// give: exponents, -0, the magnitude bounds, ids of 1..19 digits with signs and
// leading zeros, CRLF, trailing blanks, a last line without '\n'.
TEST(NativeLogReader, NumbersAndIdsReadAsFromCharsWhateverTheirSpelling) {
  const std::string path = WriteTemp(
      "numbers.log",
      "GRAPHSLAM_LOG 1\r\n"
      "POSE 0 0 0 0 0 \t\r\n"
      "POSE -7 1\r\n"
      "POSE 1234567890123456789 2\n"
      "POSE 000042 3\n"
      "FIX 0\n"
      "RB -7 5 2.5E+2 -0 1e2 0 4e2\n"
      "RB -7 +5 1e-300 -0.0 1e2 0 4e2   \n"
      "RB 1234567890123456789 999999999999999 1e9 3.25e-1 1e2 0 4e2\n"
      "XY 42 9007199254740993 -1e9 0.5 1e15 -0 1e-3\n"
      "XY -0 -0 1 2 1e15 -0 1e-3");
  StatusOr<core::Problem2d> problem = ReadNativeLog(path);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->pose_ids, (std::vector<int64_t>{0, -7, 1234567890123456789, 42}));
  EXPECT_EQ(problem->feature_ids,
            (std::vector<int64_t>{5, 999999999999999, 9007199254740993, 0}));
  ASSERT_EQ(problem->observations.size(), 5u);
  const auto& o = problem->observations;
  EXPECT_EQ(o[0].pose, 1);
  EXPECT_EQ(o[0].feature, 0);
  EXPECT_EQ(o[1].feature, 0);  // +5 is 5
  EXPECT_EQ(o[2].pose, 2);
  EXPECT_EQ(o[3].pose, 3);
  EXPECT_EQ(o[3].feature, 2);
  EXPECT_EQ(o[4].pose, 0);  // -0 is pose 0
  EXPECT_EQ(o[4].feature, 3);  // -0 is feature 0
  EXPECT_EQ(o[0].z.x(), 250.0);
  EXPECT_TRUE(o[0].z.y() == 0.0 && std::signbit(o[0].z.y()));
  EXPECT_EQ(o[1].z.x(), 1e-300);
  EXPECT_TRUE(std::signbit(o[1].z.y()));
  EXPECT_EQ(o[2].z.x(), 1e9);
  EXPECT_EQ(o[2].z.y(), 0.325);
  EXPECT_EQ(o[3].z.x(), -1e9);
  EXPECT_EQ(o[3].information(0, 0), 1e15);
  EXPECT_EQ(o[3].information(1, 1), 1e-3);
  EXPECT_EQ(o[2].information(1, 1), 400.0);
}

TEST(NativeLogReader, TokenizerShortcutsKeepTheErrorsOfEveryRecord) {
  const std::string header = "GRAPHSLAM_LOG 1\r\nPOSE 0 0 0 0 0\r\nPOSE 1 1\r\n";
  const std::string rb = "RB 1 4 1 0 1 0 1\r\n";
  // An integer beyond int64, a fraction, an exponent where an id goes.
  EXPECT_EQ(ReadError(header + "RB 1 99999999999999999999 1 0 1 0 1\n").message(),
            "bad.log:4: RB field 3 (feature id) is '99999999999999999999'; expected an "
            "integer id");
  EXPECT_EQ(ReadError(header + rb + "RB 1 4.0 1 0 1 0 1\n").message(),
            "bad.log:5: RB field 3 (feature id) is '4.0'; expected an integer id");
  EXPECT_EQ(ReadError(header + rb + "RB 1e0 4 1 0 1 0 1\n").message(),
            "bad.log:5: RB field 2 (pose id) is '1e0'; expected an integer id");
  EXPECT_EQ(ReadError(header + rb + "RB - 4 1 0 1 0 1\n").message(),
            "bad.log:5: RB field 2 (pose id) is '-'; expected an integer id");
  // Just beyond the bounds, and beyond double.
  EXPECT_EQ(ReadError(header + rb + "RB 1 4 1.0000001e9 0 1 0 1\n").message(),
            "bad.log:5: RB field 4 (measurement) is '1.0000001e9'; expected |x| <= 1e9 "
            "(the bound on coordinates, angles and measurements)");
  EXPECT_EQ(ReadError(header + rb + "RB 1 4 1 0 1e16 0 1\n").message(),
            "bad.log:5: RB field 6 (information) is '1e16'; expected |x| <= 1e15 (the "
            "bound on information entries)");
  EXPECT_EQ(ReadError(header + rb + "RB 1 4 1 1e400 1 0 1\n").message(),
            "bad.log:5: RB field 5 (measurement) is '1e400'; expected a number");
  EXPECT_EQ(ReadError(header + rb + "RB 1 4 1 0x1 1 0 1\n").message(),
            "bad.log:5: RB field 5 (measurement) is '0x1'; expected a number");
  // A repeated definite information, then an indefinite one, then the
  // definite one again: the indefinite one is caught at its line.
  EXPECT_EQ(ReadError(header + rb + rb + "RB 1 4 1 0 1 2 1\r\n" + rb).message(),
            "bad.log:6: RB information [1 2 1] is not positive definite; expected a "
            "symmetric positive definite matrix (i11 i12 i22)");
  EXPECT_EQ(ReadError(header + rb + "RB 1 4 1 0 -0 0 1\n").message(),
            "bad.log:5: RB information [-0 0 1] is not positive definite; expected a "
            "symmetric positive definite matrix (i11 i12 i22)");
  // A last line cut short, without '\n'.
  EXPECT_EQ(ReadError(header + rb + "RB 1 4 1 0").message(),
            "bad.log:5: RB has 5 fields; expected 8");
  EXPECT_EQ(ReadError(header + rb + "RB 1 4 1 0 1 0 1 \t\r\nRB 1 4 1 0 1 0 ").message(),
            "bad.log:6: RB has 7 fields; expected 8");
}

}  // namespace
}  // namespace graphslam::storage
