// The registered cloud written as binary_compressed .pcd and read back with
// PCL's own reader (pcl::io::loadPCDFile into pcl::PointXYZI).
#include "storage/pcd_io.h"

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <filesystem>
#include <random>

namespace graphslam::map {
namespace {

TEST(PcdIoTest, VoxelCloudRoundTripsThroughPcl) {
  Scan scan;
  scan.run = 3;
  std::vector<Eigen::Vector3f> world;
  // Two points in voxel (0,0,0), one in (1,0,0), one in (-1,-1,0) at 0.5 m.
  world = {{0.1f, 0.1f, 0.1f}, {0.3f, 0.2f, 0.4f}, {0.7f, 0.2f, 0.2f}, {-0.2f, -0.3f, 0.1f}};
  scan.points = world;
  scan.intensity = {10.0f, 20.0f, 5.0f, 1.0f};
  VoxelCloud cloud(0.5);
  cloud.Add(world, scan);
  ASSERT_EQ(cloud.size(), 3u);
  const std::string path = ::testing::TempDir() + "/pcd_io_test.pcd";
  ASSERT_TRUE(WritePcd(path, cloud).ok());

  pcl::PointCloud<pcl::PointXYZI> read;
  ASSERT_EQ(pcl::io::loadPCDFile(path, read), 0);
  ASSERT_EQ(read.size(), 3u);
  // Ascending voxel order: (-1,-1,0) < (0,0,0) < (1,0,0).
  EXPECT_FLOAT_EQ(read[0].x, -0.2f);
  EXPECT_FLOAT_EQ(read[0].intensity, 1.0f);
  EXPECT_FLOAT_EQ(read[1].x, 0.2f);  // centroid of the two points
  EXPECT_FLOAT_EQ(read[1].y, 0.15f);
  EXPECT_FLOAT_EQ(read[1].z, 0.25f);
  EXPECT_FLOAT_EQ(read[1].intensity, 15.0f);
  EXPECT_FLOAT_EQ(read[2].x, 0.7f);

  StatusOr<PcdContents> contents = ReadPcd(path);
  ASSERT_TRUE(contents.ok()) << contents.status().ToString();
  EXPECT_EQ(contents->data_type, "binary_compressed");
  ASSERT_EQ(contents->run.size(), 3u);
  EXPECT_EQ(contents->run[1], 3.0f);
}

TEST(PcdIoTest, XyzOnlyWhenNoIntensityOrRun) {
  Scan scan;
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-20.0f, 20.0f);
  for (int i = 0; i < 5000; ++i) scan.points.emplace_back(u(rng), u(rng), u(rng));
  VoxelCloud cloud(0.1);
  cloud.Add(scan.points, scan);
  const std::string path = ::testing::TempDir() + "/pcd_io_xyz.pcd";
  ASSERT_TRUE(WritePcd(path, cloud).ok());
  pcl::PCLPointCloud2 blob;
  ASSERT_EQ(pcl::io::loadPCDFile(path, blob), 0);
  ASSERT_EQ(blob.fields.size(), 3u);
  EXPECT_EQ(blob.width * blob.height, cloud.size());
  pcl::PointCloud<pcl::PointXYZ> xyz;
  ASSERT_EQ(pcl::io::loadPCDFile(path, xyz), 0);
  // Every input point lies in the voxel of some output point (5000 random
  // points in 40 m cubed at 0.1 m: all distinct voxels, so each is its own centroid).
  ASSERT_EQ(xyz.size(), 5000u);
  double sum_in = 0, sum_out = 0;
  for (const auto& p : scan.points) sum_in += p.x() + p.y() + p.z();
  for (const auto& p : xyz) sum_out += p.x + p.y + p.z;
  EXPECT_NEAR(sum_in, sum_out, 1e-2);
}

TEST(PcdIoTest, UnreadableFileIsAnError) {
  EXPECT_FALSE(ReadPcd(::testing::TempDir() + "/does_not_exist.pcd").ok());
}

}  // namespace
}  // namespace graphslam::map
