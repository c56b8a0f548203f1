// Scan chunks on disk: round trip, chunking, and detection of damage.
#include "storage/scan_store.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

namespace graphslam::map {
namespace {

std::vector<Scan> RandomScans(int n) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-10.0f, 10.0f);
  std::vector<Scan> scans;
  for (int s = 0; s < n; ++s) {
    Scan scan;
    scan.pose = 2 * s;
    scan.run = s % 2;
    scan.sensor_pose.q = Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * s, Eigen::Vector3d::UnitZ()));
    scan.sensor_pose.t = Eigen::Vector3d(s, -s, 0.5);
    for (int i = 0; i < 100 + s; ++i) scan.points.emplace_back(u(rng), u(rng), u(rng));
    if (s % 3 == 0) {
      for (size_t i = 0; i < scan.points.size(); ++i) scan.intensity.push_back(u(rng));
    }
    scans.push_back(std::move(scan));
  }
  return scans;
}

TEST(ScanStoreTest, RoundTripOverSeveralChunks) {
  const std::string dir = ::testing::TempDir() + "/scan_store_roundtrip";
  std::filesystem::remove_all(dir);
  const std::vector<Scan> scans = RandomScans(10);
  StatusOr<std::unique_ptr<ScanStoreWriter>> writer = ScanStoreWriter::Create(dir, 3000);
  ASSERT_TRUE(writer.ok());
  for (const Scan& scan : scans) ASSERT_TRUE((*writer)->Add(scan).ok());
  ASSERT_FALSE(DiskScanStore::Exists(dir));  // no manifest before Finish
  ASSERT_TRUE((*writer)->Finish().ok());
  StatusOr<std::unique_ptr<DiskScanStore>> store = DiskScanStore::Open(dir);
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  EXPECT_GT((*store)->NumChunks(), 2);
  EXPECT_EQ((*store)->total_scans(), 10);
  std::vector<Scan> read, chunk;
  for (int64_t k = 0; k < (*store)->NumChunks(); ++k) {
    ASSERT_TRUE((*store)->Load(k, &chunk).ok());
    read.insert(read.end(), chunk.begin(), chunk.end());
  }
  ASSERT_EQ(read.size(), scans.size());
  for (size_t s = 0; s < scans.size(); ++s) {
    EXPECT_EQ(read[s].pose, scans[s].pose);
    EXPECT_EQ(read[s].run, scans[s].run);
    EXPECT_EQ(read[s].sensor_pose.t, scans[s].sensor_pose.t);
    EXPECT_EQ(read[s].sensor_pose.q.coeffs(), scans[s].sensor_pose.q.coeffs());
    EXPECT_EQ(read[s].points, scans[s].points);
    EXPECT_EQ(read[s].intensity, scans[s].intensity);
  }
}

TEST(ScanStoreTest, FlippedByteIsCorruption) {
  const std::string dir = ::testing::TempDir() + "/scan_store_damage";
  std::filesystem::remove_all(dir);
  StatusOr<std::unique_ptr<ScanStoreWriter>> writer = ScanStoreWriter::Create(dir);
  ASSERT_TRUE(writer.ok());
  for (const Scan& scan : RandomScans(3)) ASSERT_TRUE((*writer)->Add(scan).ok());
  ASSERT_TRUE((*writer)->Finish().ok());
  const std::string chunk = dir + "/scans/000000.gss";
  {
    std::fstream f(chunk, std::ios::in | std::ios::out | std::ios::binary);
    f.seekp(200);
    f.put('\x5a');
  }
  StatusOr<std::unique_ptr<DiskScanStore>> store = DiskScanStore::Open(dir);
  ASSERT_TRUE(store.ok());
  std::vector<Scan> scans;
  const Status status = (*store)->Load(0, &scans);
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.ToString().find("000000.gss: scan record 0: checksum mismatch"), std::string::npos)
      << status.ToString();
  // Truncation.
  std::filesystem::resize_file(chunk, std::filesystem::file_size(chunk) - 5);
  EXPECT_FALSE((*store)->Load(0, &scans).ok());
}

}  // namespace
}  // namespace graphslam::map
