// The 3DTK uos reader on the dataset's real scans: counts, units, frames.
#include "storage/threedtk_reader.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "tests/testing/datasets.h"

namespace graphslam::map {
namespace {

TEST(ThreeDtkReaderTest, ListsTheThreeScans) {
  GS_REQUIRE_DATASET("3dtk_uos_scans/scan000.3d");
  StatusOr<std::vector<int>> numbers = List3dtkScans(testing::DatasetPath("3dtk_uos_scans"));
  ASSERT_TRUE(numbers.ok()) << numbers.status().ToString();
  EXPECT_EQ(*numbers, (std::vector<int>{0, 1, 2}));
}

TEST(ThreeDtkReaderTest, PointsInMetresRightHandedZUp) {
  GS_REQUIRE_DATASET("3dtk_uos_scans/scan000.3d");
  const std::string dir = testing::DatasetPath("3dtk_uos_scans");
  StatusOr<Scan> scan = Read3dtkScan(dir, 0, 0);
  ASSERT_TRUE(scan.ok()) << scan.status().ToString();
  // INDEX.md: 81,360 points per scan.
  EXPECT_EQ(scan->points.size(), 81360u);
  EXPECT_TRUE(scan->intensity.empty());
  // First line "10.1 0 0" (cm, 3DTK x = right) -> 0.101 m to the right = -y.
  EXPECT_FLOAT_EQ(scan->points[0].x(), 0.0f);
  EXPECT_FLOAT_EQ(scan->points[0].y(), -0.101f);
  EXPECT_FLOAT_EQ(scan->points[0].z(), 0.0f);
  // Extent in 3DTK: x in [-3276.58, 3275.89] cm, y (up) in [-637.049, 2257.76]
  // cm, so within ~33 m horizontally and from -6.4 m to 22.6 m vertically.
  float zmin = 1e9f, zmax = -1e9f, rmax = 0.0f;
  for (const Eigen::Vector3f& p : scan->points) {
    zmin = std::min(zmin, p.z());
    zmax = std::max(zmax, p.z());
    rmax = std::max(rmax, p.head<2>().norm());
  }
  EXPECT_NEAR(zmin, -6.37049f, 1e-4f);
  EXPECT_NEAR(zmax, 22.5776f, 1e-4f);
  EXPECT_LT(rmax, 50.0f);
  EXPECT_GT(rmax, 30.0f);
  // scan000.pose is the identity.
  EXPECT_NEAR(scan->sensor_pose.t.norm(), 0.0, 1e-12);
  EXPECT_NEAR(std::abs(scan->sensor_pose.q.w()), 1.0, 1e-12);
}

TEST(ThreeDtkReaderTest, PoseConvertsUnitsAndHandedness) {
  GS_REQUIRE_DATASET("3dtk_uos_scans/scan001.pose");
  const std::string dir = testing::DatasetPath("3dtk_uos_scans");
  StatusOr<Scan> scan = Read3dtkScan(dir, 1, 1);
  ASSERT_TRUE(scan.ok()) << scan.status().ToString();
  // scan001.pose: -3.10605 -7.50803 156.917 (cm; x right, y up, z forward),
  // 1.35694 -0.852409 -0.56224 (degrees). Forward 1.569 m, right 0.031 m,
  // down 0.075 m -> (x, y, z) = (1.56917, 0.0310605, -0.0750803).
  EXPECT_NEAR(scan->sensor_pose.t.x(), 1.56917, 1e-9);
  EXPECT_NEAR(scan->sensor_pose.t.y(), 0.0310605, 1e-9);
  EXPECT_NEAR(scan->sensor_pose.t.z(), -0.0750803, 1e-9);
  // The rotation is the 3DTK one conjugated by the frame change: applying it
  // to a converted vector equals converting the 3DTK-rotated vector.
  constexpr double kDeg = 3.14159265358979323846 / 180.0;
  const Eigen::Matrix3d r3dtk = ThreeDtkRotation(1.35694 * kDeg, -0.852409 * kDeg, -0.56224 * kDeg);
  const Eigen::Matrix3d c = ThreeDtkToRightHanded();
  EXPECT_NEAR(c.determinant(), -1.0, 1e-12);
  const Eigen::Vector3d v(0.3, -1.2, 2.5);
  EXPECT_LT((scan->sensor_pose.rotation() * (c * v) - c * (r3dtk * v)).norm(), 1e-12);
  // A 1.357 degree pitch-ish rotation: about 1.7 degrees in total.
  const double angle = Eigen::AngleAxisd(scan->sensor_pose.q).angle();
  EXPECT_NEAR(angle / kDeg, std::sqrt(1.35694 * 1.35694 + 0.852409 * 0.852409 + 0.56224 * 0.56224),
              0.05);
}

TEST(ThreeDtkReaderTest, MalformedLineNamesFileAndLine) {
  const std::string dir = ::testing::TempDir() + "/threedtk_bad";
  std::filesystem::create_directories(dir);
  std::ofstream(dir + "/scan000.pose") << "0 0 0\n0 0 0\n";
  std::ofstream(dir + "/scan000.3d") << "1 2 3\n4 5 6\n7 eight 9\n";
  StatusOr<Scan> scan = Read3dtkScan(dir, 0, 0);
  ASSERT_FALSE(scan.ok());
  EXPECT_NE(scan.status().ToString().find("scan000.3d:3"), std::string::npos)
      << scan.status().ToString();
  std::ofstream(dir + "/scan000.pose") << "0 0 0\n0 0\n";
  EXPECT_FALSE(Read3dtkScan(dir, 0, 0).ok());
}

}  // namespace
}  // namespace graphslam::map
