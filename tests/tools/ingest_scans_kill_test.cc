// kill -9 during `graphslam ingest` of a native log with SCAN records (its
// .pcd files written here by PCL), then `ingest --resume`: the store, its
// scan chunks included, is byte for byte the uninterrupted ingest's -- no scan
// lost or written twice (partition/ingest/ingest_scans.h). And `graphslam map STORE/`
// writes the same .bt and .pcd as `graphslam map LOG`.
#include <gtest/gtest.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "tests/testing/directory_bytes.h"
#include "tests/testing/kill_nine.h"
#include "tests/testing/subprocess.h"
#include "tests/tools/out_of_core_fixture.h"

namespace {

namespace fs = std::filesystem;

using graphslam::testing::ReadWholeFile;
using graphslam::testing::RunGraphslam;

class IngestScansKillTest : public graphslam::testing::OutOfCoreFixture {
 protected:
  // Appends a SCAN record to the first `scans` poses of the log at `input`,
  // naming one of 6 .pcd files (relative to the log's folder).
  void AddScans(const std::string& input, int scans) {
    const fs::path folder = fs::path(input).parent_path();
    fs::create_directories(folder / "pcd");
    for (int k = 0; k < 6; ++k) {
      pcl::PointCloud<pcl::PointXYZI> cloud;
      for (int i = 0; i < 900; ++i) {
        const double angle = 2.0 * M_PI * i / 900.0;
        const double range = 6.0 + 0.5 * std::sin(5 * angle + k);
        cloud.push_back(pcl::PointXYZI(static_cast<float>(range * std::cos(angle)), 0.0f,
                                       static_cast<float>(range * std::sin(angle)),
                                       static_cast<float>(i % 97)));
      }
      ASSERT_EQ(pcl::PCDWriter().writeBinaryCompressed(
                    (folder / "pcd" / ("s" + std::to_string(k) + ".pcd")).string(), cloud),
                0);
    }
    std::vector<std::string> pose_ids;
    {
      std::ifstream in(input);
      std::string line;
      while (std::getline(in, line) && static_cast<int>(pose_ids.size()) < scans) {
        std::istringstream fields(line);
        std::string tag, id;
        if (fields >> tag >> id && tag == "POSE") pose_ids.push_back(id);
      }
    }
    std::ofstream out(input, std::ios::app);
    for (size_t i = 0; i < pose_ids.size(); ++i)
      out << "SCAN " << pose_ids[i] << " pcd/s" << i % 6 << ".pcd\n";
  }
};

TEST_F(IngestScansKillTest, KillNineThenResumeGivesTheSameStoreWithItsScans) {
  const std::string input = Simulate(3000, 5);
  AddScans(input, 240);
  const std::vector<std::string> options = {
      "--chunk-observations", "128", "--buffer-observations", "512", "--checkpoint-seconds", "0",
      "--scan-chunk-size",    "48K", "-q"};
  auto ingest = [&](const fs::path& store, bool resume) {
    std::vector<std::string> args = {"ingest", input, "-o", store.string()};
    args.insert(args.end(), options.begin(), options.end());
    if (resume) args.push_back("--resume");
    return args;
  };
  ASSERT_EQ(RunGraphslam(ingest(dir_ / "full", false)), 0);
  const auto expected = graphslam::testing::FilesUnder(dir_ / "full");
  int scan_chunks = 0;
  for (const auto& [name, bytes] : expected) scan_chunks += name.rfind("scans/0", 0) == 0;
  ASSERT_GT(scan_chunks, 30);  // 240 scans of 14 KiB in 48 KiB chunks
  ASSERT_TRUE(expected.count("scans/SCANS.json"));

  const fs::path store = dir_ / "store";
  // After the first pass, during the chunk writes, and early and late in the
  // scan copy (storage/stop_point.h).
  for (const std::string point :
       {"ingest_pass1", "ingest_chunks 30", "ingest_scan_chunks 2", "ingest_scan_chunks 25"}) {
    SCOPED_TRACE("killed at " + point);
    fs::remove_all(store);
    ASSERT_TRUE(graphslam::testing::SpawnAndKillAtStopPoint(ingest(store, false), point))
        << "the ingest ended before " << point;
    EXPECT_FALSE(fs::exists(store / "MANIFEST.json")) << "a killed ingest committed";
    EXPECT_FALSE(fs::exists(store / "scans" / "SCANS.json")) << "killed, yet scans committed";
    ASSERT_EQ(RunGraphslam(ingest(store, true)), 0);
    graphslam::testing::ExpectSameFiles(graphslam::testing::FilesUnder(store), expected);
  }

  // The map from the store equals the map from the log (and its .pcd files).
  const std::vector<std::string> map_options = {"--resolution", "0.25", "--max-range", "10", "-q"};
  std::vector<std::string> from_store = {"map", store.string(), "--bt", (dir_ / "store.bt").string(),
                                         "--pcd", (dir_ / "store.pcd").string()};
  std::vector<std::string> from_log = {"map", input, "--bt", (dir_ / "log.bt").string(), "--pcd",
                                       (dir_ / "log.pcd").string()};
  from_store.insert(from_store.end(), map_options.begin(), map_options.end());
  from_log.insert(from_log.end(), map_options.begin(), map_options.end());
  ASSERT_EQ(RunGraphslam(from_store), 0);
  ASSERT_EQ(RunGraphslam(from_log), 0);
  const std::string bt = ReadWholeFile(dir_ / "store.bt");
  EXPECT_GT(bt.size(), 1000u);
  EXPECT_TRUE(bt == ReadWholeFile(dir_ / "log.bt"));
  EXPECT_TRUE(ReadWholeFile(dir_ / "store.pcd") == ReadWholeFile(dir_ / "log.pcd"));
}

}  // namespace
