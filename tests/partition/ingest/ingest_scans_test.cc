// The ingest copies the .pcd scans a native log names into the store's scan
// chunks (partition/ingest/ingest_scans.h): the map built from STORE/scans/ is the
// map built from the log and its .pcd files, byte for byte (.bt and .pcd),
// and it needs neither once ingested. Missing and unreadable .pcd files are
// errors naming log:line and the file, and leave no store that opens.
#include "partition/ingest/ingest_scans.h"

#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "partition/ingest/streaming_ingest.h"
#include "storage/env.h"
#include "storage/native_log_scans.h"
#include "storage/scan_store.h"
#include "tests/testing/directory_bytes.h"
#include "tools/map_builder.h"

namespace graphslam::partition {
namespace {

namespace fs = std::filesystem;

using graphslam::testing::ReadWholeFile;

class IngestScansTest : public ::testing::Test {
 protected:
  void SetUp() override {
    fs::remove_all(root_);
    fs::create_directories(root_ / "pcd");
  }
  void TearDown() override { fs::remove_all(root_); }

  // Scan k: a wall 3 m to the left of the pose (sensor frame y = 3) and a
  // patch of ground, with a few points per scan that differ by k; written by
  // PCL in several encodings, with intensity on odd k.
  void WriteScan(int k, const fs::path& path) {
    pcl::PointCloud<pcl::PointXYZI> cloud;
    for (int i = 0; i < 12; ++i) {
      for (int j = 0; j < 8; ++j) {
        pcl::PointXYZI p;
        p.x = 0.13f * static_cast<float>(i) - 0.7f + 0.01f * static_cast<float>(k % 3);
        p.y = 3.0f;
        p.z = 0.21f * static_cast<float>(j) - 0.5f;
        p.intensity = static_cast<float>(i * 8 + j + k);
        cloud.push_back(p);
      }
    }
    for (int i = 0; i < 6; ++i) {
      pcl::PointXYZI p;
      p.x = 0.4f * static_cast<float>(i);
      p.y = -1.0f - 0.1f * static_cast<float>(k % 4);
      p.z = -1.2f;
      p.intensity = 1.0f;
      cloud.push_back(p);
    }
    pcl::PCDWriter writer;
    if (k % 2 == 1) {
      ASSERT_EQ(writer.writeBinaryCompressed(path.string(), cloud), 0);
    } else {
      pcl::PointCloud<pcl::PointXYZ> xyz;
      for (const pcl::PointXYZI& p : cloud) xyz.push_back(pcl::PointXYZ(p.x, p.y, p.z));
      ASSERT_EQ(k % 4 == 0 ? writer.writeBinary(path.string(), xyz)
                           : writer.writeASCII(path.string(), xyz),
                0);
    }
  }

  // 30 poses along x, 8 landmarks seen from every pose, a SCAN per pose
  // (pose 7 twice; pose 9 by absolute path), then `extra` lines.
  void WriteLog(const std::string& extra = "") {
    std::ofstream out(log_);
    out.precision(17);
    out << "GRAPHSLAM_LOG 1\n";
    constexpr int kPoses = 30;
    for (int i = 0; i < kPoses; ++i) {
      out << "POSE " << 100 + i << " " << i << " " << 0.5 * i << " " << 0.02 * i << " "
          << 0.01 * i << "\n";
      if (i == 0) out << "FIX 100\n";
      if (i > 0) out << "ODOM " << 99 + i << " " << 100 + i << " 0.5 0 0 100 0 0 100 0 100\n";
      for (int f = 0; f < 8; ++f) {
        const double dx = 2.0 * f - 0.5 * i, dy = 4.0;
        out << "RB " << 100 + i << " " << f << " " << std::hypot(dx, dy) << " "
            << std::atan2(dy, dx) << " 100 0 400\n";
      }
      std::string name = "s";  // (not "s" + to_string: GCC 12's -Wrestrict false positive)
      name += std::to_string(i) + ".pcd";
      const fs::path pcd = root_ / "pcd" / name;
      WriteScan(i, pcd);
      out << "SCAN " << 100 + i << " " << (i == 9 ? pcd : fs::path("pcd") / name).string() << "\n";
      if (i == 7) out << "SCAN 107 pcd/s3.pcd\n";
    }
    out << extra;
  }

  Status Ingest(const fs::path& store, int64_t scan_chunk_bytes = 4096) {
    StreamingIngestOptions options;
    options.format = storage::InputFormat::kNative;
    options.max_observations_per_chunk = 64;
    options.buffer_observations = 128;
    options.scan_chunk_bytes = scan_chunk_bytes;
    IngestSummary summary;
    Status status = IngestToStore(storage::Env::Default(), log_.string(), store.string(), options,
                                  &summary);
    summary_ = summary;
    return status;
  }

  const fs::path root_ =
      fs::temp_directory_path() / ("graphslam_ingest_scans_" + std::to_string(::getpid()));
  const fs::path log_ = root_ / "run.log";
  IngestSummary summary_;
};

map::MapOptions MapTo(const fs::path& stem) {
  map::MapOptions options;
  options.fusion.resolution = 0.2;
  options.fusion.max_range = 8.0;
  options.bt_path = stem.string() + ".bt";
  options.pcd_path = stem.string() + ".pcd";
  return options;
}

TEST_F(IngestScansTest, MapFromTheStoreEqualsTheMapFromTheLogAndNeedsNeither) {
  WriteLog();
  const fs::path store = root_ / "store";
  ASSERT_TRUE(Ingest(store).ok());
  EXPECT_TRUE(fs::exists(store / "MANIFEST.json"));
  EXPECT_FALSE(fs::exists(store / "work"));
  EXPECT_EQ(summary_.scans.scans, 31);
  EXPECT_EQ(summary_.scans.points, 31 * 102);
  EXPECT_GT(summary_.scans.chunks, 3);  // 4 KiB chunks: every chunk a few scans

  StatusOr<std::unique_ptr<map::NativeLogScanSource>> from_log =
      map::NativeLogScanSource::Open(log_.string());
  ASSERT_TRUE(from_log.ok()) << from_log.status().ToString();
  StatusOr<map::MapSummary> log_map = map::BuildMap(MapTo(root_ / "log"), **from_log, nullptr);
  ASSERT_TRUE(log_map.ok()) << log_map.status().ToString();
  ASSERT_GT(log_map->occupied_leaves, 100);

  // The store alone: the log and the .pcd files are gone.
  fs::remove_all(root_ / "pcd");
  fs::remove(log_);
  StatusOr<std::unique_ptr<map::DiskScanStore>> from_store = map::DiskScanStore::Open(store.string());
  ASSERT_TRUE(from_store.ok()) << from_store.status().ToString();
  EXPECT_EQ((*from_store)->total_scans(), 31);
  StatusOr<map::MapSummary> store_map = map::BuildMap(MapTo(root_ / "store_map"), **from_store, nullptr);
  ASSERT_TRUE(store_map.ok()) << store_map.status().ToString();
  EXPECT_EQ(store_map->scans, log_map->scans);
  EXPECT_EQ(store_map->occupied_leaves, log_map->occupied_leaves);
  EXPECT_EQ(store_map->pcd_points, log_map->pcd_points);
  EXPECT_TRUE(ReadWholeFile(root_ / "store_map.bt") == ReadWholeFile(root_ / "log.bt"));
  EXPECT_TRUE(ReadWholeFile(root_ / "store_map.pcd") == ReadWholeFile(root_ / "log.pcd"));

  // With a solved trajectory too (row k = pose k): every scan is re-posed.
  std::vector<core::Pose3> poses(30);
  for (int i = 0; i < 30; ++i) poses[static_cast<size_t>(i)].t = Eigen::Vector3d(0.5 * i, 0.1, 0.3);
  fs::create_directories(root_ / "pcd");
  WriteLog();
  from_log = map::NativeLogScanSource::Open(log_.string());
  ASSERT_TRUE(from_log.ok());
  ASSERT_TRUE(map::BuildMap(MapTo(root_ / "log2"), **from_log, &poses).ok());
  ASSERT_TRUE(map::BuildMap(MapTo(root_ / "store2"), **from_store, &poses).ok());
  EXPECT_TRUE(ReadWholeFile(root_ / "store2.bt") == ReadWholeFile(root_ / "log2.bt"));
  EXPECT_TRUE(ReadWholeFile(root_ / "store2.pcd") == ReadWholeFile(root_ / "log2.pcd"));
}

TEST_F(IngestScansTest, AMissingPcdIsAnErrorNamingTheLineAndTheFile) {
  WriteLog("SCAN 105 pcd/gone.pcd\n");
  const std::string text = ReadWholeFile(log_);
  const auto line = std::count(text.begin(), text.end(), '\n');  // the SCAN line is the last
  const Status status = Ingest(root_ / "store");
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.code(), Status::Code::kNotFound) << status.ToString();
  EXPECT_NE(status.message().find("run.log:" + std::to_string(line) + ":"), std::string::npos)
      << status.ToString();
  EXPECT_NE(status.message().find((root_ / "pcd" / "gone.pcd").string()), std::string::npos)
      << status.ToString();
  EXPECT_FALSE(fs::exists(root_ / "store" / "MANIFEST.json"));
  EXPECT_FALSE(fs::exists(root_ / "store" / "scans"));
}

TEST_F(IngestScansTest, AnUnreadablePcdIsAnErrorNamingTheLineAndTheFile) {
  std::ofstream(root_ / "pcd" / "bad.pcd") << "not a point cloud\n";
  WriteLog("SCAN 105 pcd/bad.pcd\n");
  const Status status = Ingest(root_ / "store");
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.code(), Status::Code::kCorruption) << status.ToString();
  EXPECT_NE(status.message().find("run.log:"), std::string::npos) << status.ToString();
  EXPECT_NE(status.message().find((root_ / "pcd" / "bad.pcd").string()), std::string::npos)
      << status.ToString();
  EXPECT_FALSE(fs::exists(root_ / "store" / "MANIFEST.json"));
  EXPECT_FALSE(map::DiskScanStore::Exists((root_ / "store").string()));
}

// An ingest that dies at a scan checkpoint (the rename of
// work/scans_progress.json after a durable scan chunk) or at the store's
// manifest, then resumes: the store, scan chunks included, is the
// uninterrupted ingest's byte for byte, and the copy went on after the
// recorded scans (none lost, none twice).
TEST_F(IngestScansTest, ResumeAfterDyingInTheScanCopyGivesTheSameStoreBytes) {
  WriteLog();
  storage::FaultInjectionEnv counting(storage::Env::Default());
  StreamingIngestOptions options;
  options.max_observations_per_chunk = 64;
  options.buffer_observations = 128;
  options.scan_chunk_bytes = 4096;
  IngestSummary summary;
  ASSERT_TRUE(IngestToStore(&counting, log_.string(), (root_ / "full").string(), options, &summary).ok());
  const auto expected = graphslam::testing::FilesUnder(root_ / "full");
  const int renames = counting.Count(storage::FaultInjectionEnv::Operation::kRename);
  const int64_t scan_chunks = summary.scans.chunks;
  ASSERT_GT(scan_chunks, 4);
  // The last renames: a progress record per scan chunk but the last (the
  // manifest follows it), then MANIFEST.json.
  int resumed_inside = 0;
  for (const int back : {0, 1, 2, static_cast<int>(scan_chunks) - 1}) {
    const int nth = renames - back;
    SCOPED_TRACE("dies at rename " + std::to_string(nth) + " of " + std::to_string(renames));
    const fs::path store = root_ / "store";
    fs::remove_all(store);
    storage::FaultInjectionEnv env(storage::Env::Default());
    env.FailAt(storage::FaultInjectionEnv::Operation::kRename, nth);
    ASSERT_FALSE(IngestToStore(&env, log_.string(), store.string(), options, &summary).ok());
    EXPECT_FALSE(fs::exists(store / "MANIFEST.json"));
    StreamingIngestOptions resume = options;
    resume.resume = true;
    ASSERT_TRUE(IngestToStore(storage::Env::Default(), log_.string(), store.string(), resume, &summary).ok());
    resumed_inside += summary.scans.resumed_from_scan > 0;
    EXPECT_EQ(summary.scans.scans, 31);
    graphslam::testing::ExpectSameFiles(graphslam::testing::FilesUnder(store), expected);
  }
  EXPECT_GE(resumed_inside, 3);
}

TEST_F(IngestScansTest, ALogWithoutScansLeavesNoScansOfAnEarlierIngest) {
  WriteLog();
  const fs::path store = root_ / "store";
  ASSERT_TRUE(Ingest(store).ok());
  ASSERT_TRUE(map::DiskScanStore::Exists(store.string()));
  std::ofstream(log_) << "GRAPHSLAM_LOG 1\nPOSE 1 0 0 0 0\nFIX 1\nPOSE 2 1 1 0 0\n"
                      << "ODOM 1 2 1 0 0 100 0 0 100 0 100\nRB 1 5 2 0.5 100 0 400\n"
                      << "RB 2 5 1.5 0.9 100 0 400\n";
  ASSERT_TRUE(Ingest(store).ok());
  EXPECT_EQ(summary_.scans.scans, 0);
  EXPECT_FALSE(fs::exists(store / "scans"));
}

}  // namespace
}  // namespace graphslam::partition
