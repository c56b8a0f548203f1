// The KITTI odometry poses reader (storage/kitti_pose_reader.h): index and
// times-file stamps, the camera -> vehicle frame, and malformed input named
// by file and line.
#include "storage/kitti_pose_reader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>

namespace graphslam::storage {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("gs_kitti_" + std::to_string(::getpid()) + "_" + name))
                               .string();
  std::ofstream(path) << text;
  return path;
}

// A KITTI line for a camera that turned left by `yaw` (about the camera's
// -y axis, which points up) and sits at camera position (x, y, z).
std::string Line(double yaw, double x, double y, double z) {
  const Eigen::Matrix3d r = Eigen::AngleAxisd(yaw, -Eigen::Vector3d::UnitY()).toRotationMatrix();
  char text[512];
  std::snprintf(text, sizeof(text), "%.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e %.9e\n",
                r(0, 0), r(0, 1), r(0, 2), x, r(1, 0), r(1, 1), r(1, 2), y, r(2, 0), r(2, 1),
                r(2, 2), z);
  return text;
}

TEST(KittiPoseReader, StampsAreFrameIndicesAndTheBodyFrameIsForwardLeftUp) {
  // Frame 1: 10 m forward (camera z) and 2 m to the right (camera x), turned
  // left by 0.3 rad: in the vehicle frame x = 10, y = -2, yaw = +0.3.
  const std::string path = WriteTemp("00.txt", Line(0, 0, 0, 0) + Line(0.3, 2, -0.1, 10));
  StatusOr<std::vector<StampedPose3>> poses = ReadKittiPoses(path);
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  ASSERT_EQ(poses->size(), 2u);
  EXPECT_EQ((*poses)[0].stamp, 0.0);
  EXPECT_EQ((*poses)[1].stamp, 1.0);
  EXPECT_NEAR(((*poses)[1].position - Eigen::Vector3d(2, -0.1, 10)).norm(), 0.0, 1e-8);
  const StampedPose3 body = KittiCameraToBody((*poses)[1]);
  const core::Pose2 planar = ProjectToPlane(body);
  EXPECT_NEAR(planar.x(), 10.0, 1e-8);
  EXPECT_NEAR(planar.y(), -2.0, 1e-8);
  EXPECT_NEAR(body.position.z(), 0.1, 1e-8);  // camera y is down
  EXPECT_NEAR(planar.z(), 0.3, 1e-8);
  EXPECT_NEAR(ProjectToPlane(KittiCameraToBody((*poses)[0])).norm(), 0.0, 1e-12);
}

TEST(KittiPoseReader, TimesFileGivesTheStamps) {
  const std::string path = WriteTemp("01.txt", Line(0, 0, 0, 0) + Line(0, 0, 0, 1));
  const std::string times = WriteTemp("times.txt", "0.000000e+00\n1.036064e-01\n");
  StatusOr<std::vector<StampedPose3>> poses = ReadKittiPoses(path, times);
  ASSERT_TRUE(poses.ok()) << poses.status().ToString();
  EXPECT_DOUBLE_EQ((*poses)[1].stamp, 0.1036064);
}

TEST(KittiPoseReader, RejectsMalformedInputNamingFileAndLine) {
  const std::string good = Line(0, 0, 0, 0);
  struct Case {
    std::string contents;
    std::string expected;
  };
  const Case cases[] = {
      {good + "1 0 0 0 0 1 0 0 0 0 1\n",
       "bad.txt:2: KITTI pose has 11 fields; expected 12 (the 3x4 matrix [R | t] row by row)"},
      {good + "1 0 0 x 0 1 0 0 0 0 1 0\n", "bad.txt:2: KITTI pose field 4 (matrix) is 'x'"},
      {"\n" + good + "2 0 0 0 0 1 0 0 0 0 1 0\n",
       "bad.txt:3: rotation block has max |R^T R - I| = 3 and det 2; expected a rotation"},
      {"-1 0 0 0 0 1 0 0 0 0 1 0\n", "bad.txt:1: rotation block has max |R^T R - I| = 0 and det "
                                     "-1; expected a rotation"},
  };
  for (const Case& c : cases) {
    const Status status = ReadKittiPoses(WriteTemp("bad.txt", c.contents)).status();
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_NE(status.message().find(c.expected), std::string::npos)
        << status.message() << "\nexpected: " << c.expected;
  }
  const std::string path = WriteTemp("02.txt", good + good);
  const Status short_times = ReadKittiPoses(path, WriteTemp("t1.txt", "0\n")).status();
  EXPECT_TRUE(short_times.IsCorruption());
  EXPECT_NE(short_times.message().find("t1.txt: 1 times for 2 poses in"), std::string::npos)
      << short_times.message();
  const Status backwards = ReadKittiPoses(path, WriteTemp("t2.txt", "1\n0.5\n")).status();
  EXPECT_NE(backwards.message().find("t2.txt:2: time 0.5 is below the previous one, 1"),
            std::string::npos)
      << backwards.message();
  const Status two = ReadKittiPoses(path, WriteTemp("t3.txt", "0 1\n")).status();
  EXPECT_NE(two.message().find("t3.txt:1: time line has 2 fields; expected 1"), std::string::npos)
      << two.message();
  EXPECT_TRUE(ReadKittiPoses(path + ".missing").status().IsNotFound());
}

}  // namespace
}  // namespace graphslam::storage
