// The bounded voxel cloud (storage/tiled_voxel_cloud.h): with a budget so
// small that every scan spills tiles to disk and reads them back, the .pcd is
// byte for byte the one of an unbounded budget, and both hold exactly the
// points of the in-memory reference VoxelCloud (same voxels, same centroid,
// mean intensity and first run, bit for bit), read back by PCL's own
// loadPCDFile with the fields x y z [intensity] [run]. The streamed
// binary_compressed data spans several LZF segments per column.
#include "storage/tiled_voxel_cloud.h"

#include <gtest/gtest.h>
#include <pcl/PCLPointCloud2.h>
#include <pcl/conversions.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <vector>

#include "storage/pcd_io.h"
#include "tests/testing/directory_bytes.h"

namespace graphslam::map {
namespace {

namespace fs = std::filesystem;

using graphslam::testing::ReadWholeFile;

// Scans along a drive (1 m apart, as a robot's), each of random points within
// 4 m of its pose, half of them clustered so voxels collect several points
// from several scans; tiles of 3.2 m, so a scan touches a few tiles and
// neighbouring scans share them.
std::vector<Scan> RandomScans(int count, int points, bool intensity, bool run, uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> local(-4.0f, 4.0f), height(-1.0f, 3.0f);
  std::normal_distribution<float> jitter(0.0f, 0.05f);
  std::vector<Scan> scans(static_cast<size_t>(count));
  for (int s = 0; s < count; ++s) {
    Scan& scan = scans[static_cast<size_t>(s)];
    scan.run = run ? s % 3 : -1;
    // The sensor pose stays the identity: points are given in the world frame.
    const Eigen::Vector3f pose(static_cast<float>(s) - 10.0f, 0.3f * static_cast<float>(s % 7), 0.0f);
    const Eigen::Vector3f centre = pose + Eigen::Vector3f(local(random), local(random), height(random));
    for (int i = 0; i < points; ++i) {
      const Eigen::Vector3f p =
          i % 2 == 0 ? pose + Eigen::Vector3f(local(random), local(random), height(random))
                     : centre + Eigen::Vector3f(jitter(random), jitter(random), jitter(random));
      scan.points.push_back(p);
      if (intensity) scan.intensity.push_back(static_cast<float>(random() % 1000) / 7.0f);
    }
  }
  return scans;
}

class TiledVoxelCloudTest : public ::testing::Test {
 protected:
  void SetUp() override { fs::create_directories(dir_); }
  void TearDown() override { fs::remove_all(dir_); }

  // Writes `scans` through a TiledVoxelCloud with `budget` into NAME.pcd.
  TiledVoxelCloudStats Write(const std::vector<Scan>& scans, int64_t budget, const std::string& name) {
    TiledVoxelCloudOptions options;
    options.voxel = 0.1;
    options.tile_bits = 5;  // 3.2 m tiles
    options.budget_bytes = budget;
    options.spill_dir = (dir_ / (name + ".voxels")).string();
    TiledVoxelCloud cloud(options);
    for (const Scan& scan : scans) EXPECT_TRUE(cloud.Add(scan.points, scan).ok());
    const Status status = cloud.Finish((dir_ / (name + ".pcd")).string());
    EXPECT_TRUE(status.ok()) << status.ToString();
    EXPECT_FALSE(fs::exists(options.spill_dir));
    return cloud.stats();
  }

  const fs::path dir_ =
      fs::temp_directory_path() / ("graphslam_tiled_voxels_" + std::to_string(::getpid()));
};

// Each point's float fields (in PCL's field order) from a PCD read by PCL.
std::vector<std::vector<float>> LoadRows(const fs::path& path, std::vector<std::string>* names) {
  pcl::PCLPointCloud2 blob;
  EXPECT_EQ(pcl::io::loadPCDFile(path.string(), blob), 0);
  names->clear();
  for (const pcl::PCLPointField& field : blob.fields) {
    EXPECT_EQ(field.datatype, pcl::PCLPointField::FLOAT32);
    names->push_back(field.name);
  }
  std::vector<std::vector<float>> rows(static_cast<size_t>(blob.width) * blob.height);
  for (size_t i = 0; i < rows.size(); ++i) {
    for (const pcl::PCLPointField& field : blob.fields) {
      float v;
      std::memcpy(&v, blob.data.data() + i * blob.point_step + field.offset, sizeof(v));
      rows[i].push_back(v);
    }
  }
  return rows;
}

TEST_F(TiledVoxelCloudTest, ATinyBudgetSpillsYetWritesTheUnboundedBytesAndTheReferencePoints) {
  const std::vector<Scan> scans = RandomScans(40, 3000, true, true, 7);
  const TiledVoxelCloudStats unbounded = Write(scans, int64_t{1} << 40, "unbounded");
  const TiledVoxelCloudStats tiny = Write(scans, 20000, "tiny");  // ~200 voxels resident
  EXPECT_EQ(unbounded.spills, 0);
  EXPECT_GT(tiny.spills, 40);
  EXPECT_GT(tiny.reloads, 40);
  EXPECT_LE(tiny.peak_resident_bytes, unbounded.peak_resident_bytes / 4);
  EXPECT_EQ(tiny.voxels, unbounded.voxels);
  EXPECT_TRUE(ReadWholeFile(dir_ / "tiny.pcd") == ReadWholeFile(dir_ / "unbounded.pcd"));

  // Against the in-memory reference, through PCL's reader.
  VoxelCloud reference(0.1);
  for (const Scan& scan : scans) reference.Add(scan.points, scan);
  std::vector<std::string> names;
  std::vector<std::vector<float>> rows = LoadRows(dir_ / "tiny.pcd", &names);
  EXPECT_EQ(names, (std::vector<std::string>{"x", "y", "z", "intensity", "run"}));
  ASSERT_EQ(rows.size(), reference.size());
  std::vector<std::vector<float>> expected;
  for (const VoxelCloud::Point& p : reference.Points())
    expected.push_back({p.xyz.x(), p.xyz.y(), p.xyz.z(), p.intensity, p.run});
  std::sort(rows.begin(), rows.end());
  std::sort(expected.begin(), expected.end());
  EXPECT_TRUE(rows == expected) << "the voxel points differ from the reference";
}

TEST_F(TiledVoxelCloudTest, ManySegmentsAndOptionalFieldsLoadWithPcl) {
  // 400,000 distinct voxels: each column is 1.6 MB, two LZF segments.
  Scan scan;
  for (int i = 0; i < 400000; ++i)
    scan.points.emplace_back(0.1f * static_cast<float>(i % 100) + 0.05f,
                             0.1f * static_cast<float>((i / 100) % 80) + 0.05f,
                             0.1f * static_cast<float>(i / 8000) + 0.05f);
  const TiledVoxelCloudStats stats = Write({scan}, int64_t{1} << 40, "xyz");
  EXPECT_EQ(stats.voxels, 400000);
  pcl::PointCloud<pcl::PointXYZ> cloud;
  ASSERT_EQ(pcl::io::loadPCDFile((dir_ / "xyz.pcd").string(), cloud), 0);
  ASSERT_EQ(cloud.size(), 400000u);
  std::vector<std::array<float, 3>> got, want;
  for (const pcl::PointXYZ& p : cloud) got.push_back({p.x, p.y, p.z});
  for (const Eigen::Vector3f& p : scan.points) want.push_back({p.x(), p.y(), p.z()});
  std::sort(got.begin(), got.end());
  std::sort(want.begin(), want.end());
  EXPECT_TRUE(got == want);
  std::vector<std::string> names;
  LoadRows(dir_ / "xyz.pcd", &names);
  EXPECT_EQ(names, (std::vector<std::string>{"x", "y", "z"}));
  const std::string bytes = ReadWholeFile(dir_ / "xyz.pcd");
  EXPECT_NE(bytes.find("DATA binary_compressed\n"), std::string::npos);

  // Intensity without run ids: x y z intensity, as pcl::PointXYZI.
  const std::vector<Scan> scans = RandomScans(5, 2000, true, false, 3);
  Write(scans, 5000, "xyzi");
  LoadRows(dir_ / "xyzi.pcd", &names);
  EXPECT_EQ(names, (std::vector<std::string>{"x", "y", "z", "intensity"}));
  pcl::PointCloud<pcl::PointXYZI> with_intensity;
  ASSERT_EQ(pcl::io::loadPCDFile((dir_ / "xyzi.pcd").string(), with_intensity), 0);
  EXPECT_GT(with_intensity.size(), 1000u);
}

}  // namespace
}  // namespace graphslam::map
