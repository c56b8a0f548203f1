// Scans named by SCAN records of a native log (storage/native_log_scans.h):
// the .pcd files (written here by hand in PCL's ASCII format, so nothing of
// ours writes them) are read with PCL's loader, moved by their pose and
// fused by `graphslam map LOG --bt --pcd`; the wall both poses see is
// occupied in the .bt read back by OctoMap, the space in front of it is free,
// and the registered cloud lies on the wall. Missing, unreadable and
// misplaced SCAN records are errors naming log:line.
#include <gtest/gtest.h>
#include <octomap/OcTree.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "storage/native_log_reader.h"
#include "storage/native_log_scans.h"
#include "storage/pcd_io.h"
#include "tests/testing/datasets.h"
#include "tools/map_command.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

class MapNativeLogTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(root_);
    fs::create_directories(root_ / "scans");
  }
  void TearDown() override { fs::remove_all(root_); }

  // An ASCII PCD (PCL's v0.7 header) of `points`, with an intensity field
  // when `intensity` is not empty.
  void WritePcd(const fs::path& path, const std::vector<Eigen::Vector3f>& points,
                const std::vector<float>& intensity) {
    std::ofstream out(path);
    const bool with_i = !intensity.empty();
    out << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
        << "FIELDS x y z" << (with_i ? " intensity" : "") << "\n"
        << "SIZE 4 4 4" << (with_i ? " 4" : "") << "\n"
        << "TYPE F F F" << (with_i ? " F" : "") << "\n"
        << "COUNT 1 1 1" << (with_i ? " 1" : "") << "\n"
        << "WIDTH " << points.size() << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n"
        << "POINTS " << points.size() << "\nDATA ascii\n";
    for (size_t i = 0; i < points.size(); ++i) {
      out << points[i].x() << " " << points[i].y() << " " << points[i].z();
      if (with_i) out << " " << intensity[i];
      out << "\n";
    }
  }

  void WriteLog(const std::string& scan_lines) {
    std::ofstream out(log_);
    out << "GRAPHSLAM_LOG 1\n"
        << "POSE 10 0 0 0 0\n"
        << "POSE 11 1 1 2 1.5707963267948966\n"
        << "ODOM 10 11 1 2 1.5707963267948966 100 0 0 100 0 100\n"
        << scan_lines;
  }

  const fs::path root_ =
      fs::temp_directory_path() / ("graphslam_map_log_" + std::to_string(::getpid()));
  const fs::path log_ = root_ / "run.log";
};

// A wall at world x = 4.05, y in [-1.95, 2.05], z in [0.05, 2.05] (0.1 m grid), as seen
// from pose 10 (identity) and from pose 11 (at (1, 2), facing +y).
std::vector<Eigen::Vector3f> WallInFrame(double px, double py, double theta) {
  std::vector<Eigen::Vector3f> out;
  const double c = std::cos(theta), s = std::sin(theta);
  for (int iy = -20; iy <= 20; ++iy) {
    for (int iz = 0; iz <= 20; ++iz) {
      const double wx = 4.05, wy = 0.1 * iy + 0.05, wz = 0.1 * iz + 0.05;  // cell centres
      const double dx = wx - px, dy = wy - py;  // R(theta)^T (w - t)
      out.emplace_back(static_cast<float>(c * dx + s * dy), static_cast<float>(-s * dx + c * dy),
                       static_cast<float>(wz));
    }
  }
  return out;
}

TEST_F(MapNativeLogTest, PcdScansOfTheLogFuseIntoTheWall) {
  std::vector<Eigen::Vector3f> first = WallInFrame(0, 0, 0);
  std::vector<float> intensity(first.size(), 7.0f);
  first.emplace_back(NAN, NAN, NAN);  // an organized cloud's hole: dropped
  intensity.push_back(0.0f);
  WritePcd(root_ / "scans" / "a.pcd", first, intensity);
  WritePcd(root_ / "b.pcd", WallInFrame(1, 2, M_PI / 2), {});
  WriteLog("SCAN 10 scans/a.pcd\nSCAN 11 " + (root_ / "b.pcd").string() + "\n");

  // The solver's reader accepts SCAN records and sees the same problem.
  StatusOr<core::Problem2d> problem = storage::ReadNativeLog(log_.string());
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->num_poses(), 2);

  StatusOr<std::unique_ptr<map::ScanSource>> source = OpenScanSource(log_.string());
  ASSERT_TRUE(source.ok()) << source.status().ToString();
  ASSERT_EQ((*source)->NumChunks(), 2);
  std::vector<map::Scan> scans;
  ASSERT_TRUE((*source)->Load(0, &scans).ok());
  ASSERT_EQ(scans.size(), 1u);
  EXPECT_EQ(scans[0].pose, 0);
  EXPECT_EQ(scans[0].points.size(), first.size() - 1);
  ASSERT_EQ(scans[0].intensity.size(), first.size() - 1);
  EXPECT_EQ(scans[0].intensity[5], 7.0f);
  ASSERT_TRUE((*source)->Load(1, &scans).ok());
  EXPECT_EQ(scans[0].pose, 1);
  EXPECT_TRUE(scans[0].intensity.empty());
  EXPECT_NEAR(scans[0].sensor_pose.t.x(), 1.0, 1e-12);
  EXPECT_NEAR(scans[0].sensor_pose.t.y(), 2.0, 1e-12);
  for (const Eigen::Vector3f& p : map::WorldPoints(scans[0])) EXPECT_NEAR(p.x(), 4.05, 1e-5);

  // Through the binary, read back with OctoMap's and PCL's readers.
  const std::string bt = (root_ / "wall.bt").string(), pcd = (root_ / "wall.pcd").string();
  const std::string command = ::graphslam::testing::BinaryDir() + "/bin/graphslam map " +
                              log_.string() + " --bt " + bt + " --pcd " + pcd +
                              " --resolution 0.1 -q";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  octomap::OcTree tree(bt);
  int wall_occupied = 0, wall_cells = 0;
  for (double y = -1.45; y <= 1.45; y += 0.1) {
    for (double z = 0.25; z <= 1.75; z += 0.1) {
      ++wall_cells;
      const octomap::OcTreeNode* node = tree.search(4.05, y, z);
      if (node != nullptr && tree.isNodeOccupied(node)) ++wall_occupied;
      // In front of the wall, on the rays from pose 10: free.
      const octomap::OcTreeNode* front = tree.search(2.0, 0.5 * y, 0.5 * z);
      ASSERT_NE(front, nullptr);
      EXPECT_FALSE(tree.isNodeOccupied(front)) << y << " " << z;
    }
  }
  EXPECT_GT(wall_occupied, 0.95 * wall_cells) << wall_occupied << " of " << wall_cells;
  StatusOr<map::PcdContents> cloud = map::ReadPcd(pcd);
  ASSERT_TRUE(cloud.ok()) << cloud.status().ToString();
  ASSERT_GT(cloud->points.size(), 500u);
  for (const Eigen::Vector3f& p : cloud->points) EXPECT_NEAR(p.x(), 4.05, 0.05);
  EXPECT_FALSE(cloud->intensity.empty());
}

// Real PCL files: an organized binary_compressed cloud (office1, 640 x 480
// with NaN holes) and an unorganized one (car6, 10031 points).
TEST_F(MapNativeLogTest, RealPclCloudsLoadWithTheirHolesDropped) {
  GS_REQUIRE_DATASET("pcl_test_clouds/office1.pcd");
  GS_REQUIRE_DATASET("pcl_test_clouds/car6.pcd");
  WriteLog("SCAN 10 " + testing::DatasetPath("pcl_test_clouds/office1.pcd") + "\nSCAN 11 " +
           testing::DatasetPath("pcl_test_clouds/car6.pcd") + "\n");
  StatusOr<std::unique_ptr<map::ScanSource>> source = OpenScanSource(log_.string());
  ASSERT_TRUE(source.ok()) << source.status().ToString();
  std::vector<map::Scan> scans;
  ASSERT_TRUE((*source)->Load(0, &scans).ok());
  EXPECT_GT(scans[0].points.size(), 100000u);
  EXPECT_LT(scans[0].points.size(), 640u * 480u);  // the holes are gone
  for (const Eigen::Vector3f& p : scans[0].points) ASSERT_TRUE(p.allFinite());
  ASSERT_TRUE((*source)->Load(1, &scans).ok());
  EXPECT_EQ(scans[0].points.size(), 10031u);
}

TEST_F(MapNativeLogTest, MissingPcdIsAnErrorNamingTheLogLine) {
  WriteLog("SCAN 10 scans/none.pcd\n");
  StatusOr<std::unique_ptr<map::ScanSource>> source = OpenScanSource(log_.string());
  ASSERT_FALSE(source.ok());
  EXPECT_TRUE(source.status().IsNotFound());
  EXPECT_NE(source.status().ToString().find("run.log:5: SCAN file 'scans/none.pcd'"),
            std::string::npos)
      << source.status().ToString();
  // The binary exits non-zero without writing the map.
  const std::string bt = (root_ / "none.bt").string();
  const std::string command = ::graphslam::testing::BinaryDir() + "/bin/graphslam map " +
                              log_.string() + " --bt " + bt + " -q 2>/dev/null";
  EXPECT_NE(std::system(command.c_str()), 0);
  EXPECT_FALSE(fs::exists(bt));
}

TEST_F(MapNativeLogTest, UnreadablePcdIsAnErrorNamingTheLogLine) {
  std::ofstream(root_ / "scans" / "bad.pcd") << "this is not a point cloud\n";
  {
    std::ofstream out(root_ / "scans" / "noxyz.pcd");
    out << "VERSION 0.7\nFIELDS a b c\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\n"
        << "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 1\nDATA ascii\n1 2 3\n";
  }
  WriteLog("SCAN 10 scans/bad.pcd\n# a comment\nSCAN 11 scans/noxyz.pcd\n");
  StatusOr<std::unique_ptr<map::ScanSource>> source = OpenScanSource(log_.string());
  ASSERT_TRUE(source.ok()) << source.status().ToString();
  std::vector<map::Scan> scans;
  Status bad = (*source)->Load(0, &scans);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.ToString().find("run.log:5: SCAN file 'scans/bad.pcd' cannot be read"),
            std::string::npos)
      << bad.ToString();
  Status noxyz = (*source)->Load(1, &scans);
  ASSERT_FALSE(noxyz.ok());
  EXPECT_NE(noxyz.ToString().find("run.log:7: SCAN file 'scans/noxyz.pcd'"), std::string::npos)
      << noxyz.ToString();
}

TEST_F(MapNativeLogTest, MalformedScanRecordsAreRejectedByTheReader) {
  WriteLog("SCAN 12 scans/a.pcd\n");
  Status undeclared = storage::ReadNativeLog(log_.string()).status();
  EXPECT_NE(undeclared.ToString().find("run.log:5: SCAN refers to pose 12"), std::string::npos)
      << undeclared.ToString();
  WriteLog("SCAN 10\n");
  Status short_record = storage::ReadNativeLog(log_.string()).status();
  EXPECT_NE(short_record.ToString().find("run.log:5: SCAN has 2 fields; expected 3"),
            std::string::npos)
      << short_record.ToString();
}

}  // namespace
}  // namespace graphslam::tools
