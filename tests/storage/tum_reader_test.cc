// The TUM trajectory reader (storage/tum_reader.h) and the trajectory format
// detection (storage/trajectory_format.h): values, planar projection, and
// malformed input named by file and line.
#include "storage/tum_reader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "storage/trajectory_format.h"

namespace graphslam::storage {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("gs_tum_" + std::to_string(::getpid()) + "_" + name))
                               .string();
  std::ofstream(path) << text;
  return path;
}

TEST(TumReader, ReadsPosesInFileOrderAndProjectsYaw) {
  // Yaw 1 rad about z, scaled by 2 (the reader normalizes); then a pose
  // rolled by 0.3 rad about x with yaw 0.5: the projection keeps the yaw.
  const Eigen::Quaterniond rolled = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX());
  char line[256];
  std::snprintf(line, sizeof(line), "1305031102.5 4 5 6 %.17g %.17g %.17g %.17g\n", rolled.x(),
                rolled.y(), rolled.z(), rolled.w());
  const std::string path =
      WriteTemp("good.tum", "# timestamp x y z qx qy qz qw\n\n1305031102.25 1 2 3 0 0 " +
                                std::to_string(2 * std::sin(0.5)) + " " +
                                std::to_string(2 * std::cos(0.5)) + "\n" + line);
  StatusOr<std::vector<StampedPose3>> poses = ReadTumTrajectory(path);
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  ASSERT_EQ(poses->size(), 2u);
  EXPECT_DOUBLE_EQ((*poses)[0].stamp, 1305031102.25);
  EXPECT_EQ((*poses)[0].position, Eigen::Vector3d(1, 2, 3));
  EXPECT_NEAR((*poses)[0].orientation.norm(), 1.0, 1e-15);
  EXPECT_NEAR(ProjectToPlane((*poses)[0]).z(), 1.0, 1e-6);
  EXPECT_EQ(ProjectToPlane((*poses)[1]).head<2>(), Eigen::Vector2d(4, 5));
  EXPECT_NEAR(ProjectToPlane((*poses)[1]).z(), 0.5, 1e-12);
  EXPECT_EQ(*DetectTrajectoryFormat(path), TrajectoryFormat::kTum);
}

TEST(TumReader, KeepsRunsWhoseTimesStartAgain) {
  const std::string path =
      WriteTemp("runs.tum", "0 0 0 0 0 0 0 1\n1 1 0 0 0 0 0 1\n0 5 0 0 0 0 0 1\n");
  StatusOr<std::vector<StampedPose3>> poses = ReadTumTrajectory(path);
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  ASSERT_EQ(poses->size(), 3u);
  EXPECT_EQ((*poses)[2].position.x(), 5.0);
}

TEST(TumReader, RejectsMalformedLinesNamingFileAndLine) {
  const std::string good = "0.5 1 2 0 0 0 0 1\n";
  struct Case {
    std::string contents;
    std::string expected;
  };
  const Case cases[] = {
      {"# header\n" + good + "1.0 1 2 0 0 0 1\n",
       "bad.tum:3: TUM pose has 7 fields; expected 8 (t x y z qx qy qz qw)"},
      {good + "\n1.0 1 abc 0 0 0 0 1\n", "bad.tum:3: TUM pose field 3 (position) is 'abc'"},
      {good + "1.0 1 2 0 0 0 0 nan\n", "bad.tum:2: TUM pose field 8 (quaternion) is 'nan'"},
      {good + "1.0 1 2 0 0 0 0 0\n",
       "bad.tum:2: quaternion (qx qy qz qw) has norm 0; expected a unit quaternion"},
      {"1e13 1 2 0 0 0 0 1\n", "bad.tum:1: TUM pose field 1 (t) is '1e13'"},
  };
  for (const Case& c : cases) {
    const std::string path = WriteTemp("bad.tum", c.contents);
    const Status status = ReadTumTrajectory(path).status();
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_NE(status.message().find(c.expected), std::string::npos)
        << status.message() << "\nexpected: " << c.expected;
  }
  EXPECT_TRUE(ReadTumTrajectory(WriteTemp("x", "") + ".missing").status().IsNotFound());
}

TEST(TrajectoryFormat, DetectsByFieldCountAndNamesTheFirstLineOtherwise) {
  EXPECT_EQ(*DetectTrajectoryFormat(WriteTemp("k.txt", "# c\n1 0 0 0 0 1 0 0 0 0 1 0\n")),
            TrajectoryFormat::kKitti);
  const Status seven = DetectTrajectoryFormat(WriteTemp("s.txt", "\n1 2 3 4 5 6 7\n")).status();
  EXPECT_TRUE(seven.IsCorruption());
  EXPECT_NE(seven.message().find("s.txt:2: trajectory line has 7 fields; expected 8 (TUM) or 12 "
                                 "(KITTI)"),
            std::string::npos)
      << seven.message();
  EXPECT_TRUE(DetectTrajectoryFormat(WriteTemp("e.txt", "# only\n")).status().IsCorruption());
  EXPECT_TRUE(ParseTrajectoryFormat("euroc").status().IsInvalidArgument());
  EXPECT_EQ(*ParseTrajectoryFormat("kitti"), TrajectoryFormat::kKitti);
  // A times file goes with KITTI only.
  EXPECT_TRUE(ReadTrajectory(WriteTemp("t.tum", "0 0 0 0 0 0 0 1\n"), TrajectoryFormat::kTum,
                             "times.txt")
                  .status()
                  .IsInvalidArgument());
}

}  // namespace
}  // namespace graphslam::storage
