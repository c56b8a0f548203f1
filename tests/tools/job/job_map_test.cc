// The map stage of a job end to end: a simulated campus driven twice with GPS
// and a vertical laser (scans: true). The outputs exist; map.bt loads with
// OctoMap's readBinary and map.pcd with PCL (storage::ReadPcd is
// pcl::io::loadPCDFile); cells on the building walls the laser hit are
// occupied and the street space its rays crossed is free, checked against
// the 3-D world rebuilt independently from the simulator; the trajectories
// match the ground truth within the noise; the report lists the map.
#include <gtest/gtest.h>
#include <unistd.h>

#include <octomap/OcTree.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <set>
#include <sstream>

#include "partition/ingest/streaming_ingest.h"
#include "storage/env.h"
#include "storage/pcd_io.h"
#include "storage/pcd_run_names.h"
#include "storage/scan_store.h"
#include "tools/campus_simulator.h"
#include "tools/job/job_map.h"
#include "tests/tools/job/job_test_folder.h"
#include "tools/job/job_memory_budget.h"
#include "tools/job/job_runner.h"
#include "tools/job/simulated_scans.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;

constexpr int kBeams = 60;
constexpr double kMaxRange = 25.0;
constexpr double kResolution = 0.25;
constexpr double kSensorHeight = 1.5;

CampusSimulatorOptions CampusOptions() {
  CampusSimulatorOptions o;
  o.poses = 600;
  o.runs = 2;
  o.gps_every = 10;
  o.seed = 4;
  return o;
}

using JobMap = JobTestFolder;

TEST_F(JobMap, ScansAreFusedAtTheOptimizedPosesIntoAMapOfTheTrueWorld) {
  const Status status =
      Run("output: out\n"
          "threads: 2\n"
          "memory_limit: 512MiB\n"
          "map: {resolution: 0.25, max_range: 25, sensor_height: 1.5}\n"
          "runs:\n"
          "  - name: campus\n"
          "    format: simulate\n"
          "    simulate: {poses: 600, runs: 2, gps_every: 10, seed: 4, scans: true,\n"
          "               scan_beams: 60, scan_max_range: 25}\n");
  ASSERT_TRUE(status.ok()) << status.ToString();
  const fs::path out = dir_ / "out";
  for (const char* file : {"trajectories/campus_1.tum", "trajectories/campus_2.tum",
                           "features.csv", "graph.g2o", "map.bt", "map.pcd", "report.json",
                           "report.html", "log.jsonl"})
    EXPECT_TRUE(fs::exists(out / file)) << file;
  // The scans went through disk-backed chunks.
  EXPECT_TRUE(map::DiskScanStore::Exists((out / ".job/scans/campus").string()));

  // Ground truth and the 3-D world, straight from the simulators.
  StatusOr<SimulatedCampus> campus = SimulateCampus(CampusOptions());
  ASSERT_TRUE(campus.ok());
  const map::Campus3d world = MakeCampusWorld3d(CampusOptions(), *campus, kSensorHeight);

  // Trajectories: with GPS the estimate is in the true frame.
  // (The job's TUM times continue from run to run: run 2 starts 1 s after
  // run 1 ended, tools/job/job_export.h.)
  double offset = 0.0;
  for (int run = 0; run < 2; ++run) {
    std::vector<StampedPose2> truth;
    for (size_t i = 0; i < campus->true_poses.size(); ++i)
      if (campus->run_of_pose[i] == run)
        truth.push_back({offset + campus->problem.pose_stamps[i], campus->true_poses[i]});
    offset = truth.back().stamp + 1.0;
    StatusOr<std::vector<StampedPose2>> estimate =
        ReadTum((out / ("trajectories/campus_" + std::to_string(run + 1) + ".tum")).string());
    ASSERT_TRUE(estimate.ok()) << estimate.status().ToString();
    TrajectoryMatchOptions unaligned;
    unaligned.align = false;
    StatusOr<TrajectoryErrors> errors = CompareTrajectories(*estimate, truth, unaligned);
    ASSERT_TRUE(errors.ok()) << errors.status().ToString();
    EXPECT_EQ(errors->matched, static_cast<int64_t>(truth.size()));
    EXPECT_LT(errors->position_rmse, 0.5) << "run " << run;
  }

  // map.bt through OctoMap's own reader.
  octomap::OcTree tree(0.1);
  ASSERT_TRUE(tree.readBinary((out / "map.bt").string()));
  EXPECT_DOUBLE_EQ(tree.getResolution(), kResolution);
  ASSERT_GT(tree.getNumLeafNodes(), 1000u);

  // Walls and streets. For every 5th true pose, the low beams (within 25
  // degrees of horizontal) that hit a building in the true world: the cells
  // around the hit are occupied, the street halfway along the ray is free.
  auto occupied_near = [&](const Eigen::Vector3d& p) {
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const octomap::OcTreeNode* node = tree.search(p.x() + dx * kResolution,
                                                        p.y() + dy * kResolution,
                                                        p.z() + dz * kResolution);
          if (node != nullptr && tree.isNodeOccupied(node)) return true;
        }
    return false;
  };
  // The scan planes are 1 m apart (a pose every 1 m) and the cells 0.25 m:
  // free space is seen in slices across the street, so "free" means a free
  // cell within 2 cells horizontally (1 vertically) and no occupied one.
  auto free_near = [&](const Eigen::Vector3d& p) {
    bool any_free = false;
    for (int dx = -2; dx <= 2; ++dx)
      for (int dy = -2; dy <= 2; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const octomap::OcTreeNode* node = tree.search(p.x() + dx * kResolution,
                                                        p.y() + dy * kResolution,
                                                        p.z() + dz * kResolution);
          if (node == nullptr) continue;
          if (tree.isNodeOccupied(node)) return false;
          any_free = true;
        }
    return any_free;
  };
  auto on_building = [&](const Eigen::Vector3d& p) {
    for (const map::Box& b : world.buildings)
      if ((p.array() >= b.lo.array() - 0.01).all() && (p.array() <= b.hi.array() + 0.01).all())
        return true;
    return false;
  };
  int64_t walls = 0, walls_occupied = 0, street = 0, street_free = 0, street_occupied = 0;
  for (size_t k = 0; k < campus->true_poses.size(); k += 5) {
    const core::Pose3 sensor = LiftPose(campus->true_poses[k], kSensorHeight);
    const Eigen::Matrix3d r = sensor.rotation();
    for (int beam = 0; beam < kBeams; ++beam) {
      const double angle = 2.0 * std::numbers::pi * (beam + 0.5) / kBeams;
      const Eigen::Vector3d local(0.0, std::cos(angle), std::sin(angle));
      if (std::abs(local.z()) > std::sin(25.0 * std::numbers::pi / 180)) continue;
      const Eigen::Vector3d d = r * local;
      const double t = world.Cast(sensor.t, d, kMaxRange);
      if (!std::isfinite(t)) continue;
      const Eigen::Vector3d hit = sensor.t + t * d;
      if (!on_building(hit)) continue;
      ++walls;
      if (occupied_near(hit)) ++walls_occupied;
      const Eigen::Vector3d middle = sensor.t + 0.5 * t * d;
      const octomap::OcTreeNode* node = tree.search(middle.x(), middle.y(), middle.z());
      ++street;
      if (node != nullptr && tree.isNodeOccupied(node)) ++street_occupied;
      if (free_near(middle)) ++street_free;
    }
  }
  ASSERT_GT(walls, 500);
  EXPECT_GT(static_cast<double>(walls_occupied) / walls, 0.95) << walls_occupied << "/" << walls;
  EXPECT_GT(static_cast<double>(street_free) / street, 0.95) << street_free << "/" << street;
  EXPECT_EQ(street_occupied, 0);
  // And a control: the middle of a building is never seen (unknown), nor
  // free.
  for (const map::Box& b : world.buildings) {
    const Eigen::Vector3d centre = 0.5 * (b.lo + b.hi);
    const octomap::OcTreeNode* node = tree.search(centre.x(), centre.y(), 2.0);
    EXPECT_TRUE(node == nullptr || tree.isNodeOccupied(node)) << centre.transpose();
  }

  // map.pcd through PCL: binary_compressed, with the run id of every point.
  StatusOr<map::PcdContents> cloud = map::ReadPcd((out / "map.pcd").string());
  ASSERT_TRUE(cloud.ok()) << cloud.status().ToString();
  EXPECT_EQ(cloud->data_type, "binary_compressed");
  ASSERT_EQ(cloud->run.size(), cloud->points.size());
  std::set<float> runs(cloud->run.begin(), cloud->run.end());
  EXPECT_EQ(runs, (std::set<float>{0.0f, 1.0f}));
  // The name of each run index, read back from the table beside the cloud.
  StatusOr<std::vector<std::string>> names = storage::ReadPcdRunNames((out / "map.pcd").string());
  ASSERT_TRUE(names.ok()) << names.status().ToString();
  EXPECT_EQ(*names, (std::vector<std::string>{"campus_1", "campus_2"}));

  // The report says what was fused and where it went.
  const nlohmann::json report = nlohmann::json::parse(ReadFile(out / "report.json"));
  ASSERT_TRUE(report.contains("map"));
  EXPECT_EQ(report["map"]["scans"].get<int64_t>(), 600);
  EXPECT_GT(report["map"]["points"].get<int64_t>(), 10000);
  EXPECT_EQ(report["map"]["pcd_points"].get<int64_t>(), static_cast<int64_t>(cloud->points.size()));
  EXPECT_EQ(report["map"]["files"], nlohmann::json({"map.bt", "map.pcd"}));
  // The fusion's tile budget is what the 512 MiB leave beside the problem,
  // the fusion and one batch (tools/job/job_memory_budget.h).
  EXPECT_GT(report["map"]["memory_budget_bytes"].get<int64_t>(), int64_t{400} << 20);
  EXPECT_LT(report["map"]["memory_budget_bytes"].get<int64_t>(),
            (int64_t{512} << 20) - kJobBaseBytes - kJobMapFixedBytes);
  const std::string html = ReadFile(out / "report.html");
  EXPECT_NE(html.find("<figure class=\"map-image"), std::string::npos);  // the picture
  EXPECT_NE(html.find("map.bt, map.pcd</td>"), std::string::npos);
}

// memory_limit is applied: at 64 MiB the fusion's tile budget (what the
// limit leaves beside the problem, the fusion and a batch: ~17 MiB,
// tools/job/job_memory_budget.h) is below the map's ~23 MiB, so tiles spill
// to disk and the map is written as tiles (map.tiles/index.json + one .bt per
// tile); their cells are exactly those of the one-tree map of the same job at
// 1 GiB, and map.pcd is the same.
TEST_F(JobMap, TheMemoryLimitBoundsTheFusionAndTilesTheMap) {
  const std::string runs =
      "map: {resolution: 0.25, max_range: 25}\n"
      "runs:\n"
      "  - name: campus\n"
      "    format: simulate\n"
      "    simulate: {poses: 600, runs: 2, gps_every: 10, seed: 4, scans: true,\n"
      "               scan_beams: 60, scan_max_range: 25}\n";
  ASSERT_TRUE(Run("output: big\nthreads: 2\nmemory_limit: 1GiB\n" + runs).ok());
  const Status small = Run("output: small\nthreads: 2\nmemory_limit: 64MiB\n" + runs);
  ASSERT_TRUE(small.ok()) << small.ToString();
  EXPECT_EQ(ReadFile(dir_ / "big" / "map.pcd"), ReadFile(dir_ / "small" / "map.pcd"));
  EXPECT_FALSE(fs::exists(dir_ / "small" / "map.bt"));
  const nlohmann::json report = nlohmann::json::parse(ReadFile(dir_ / "small" / "report.json"));
  EXPECT_TRUE(report["map"]["tiled_output"].get<bool>());
  EXPECT_GE(report["map"]["memory_budget_bytes"].get<int64_t>(), int64_t{16} << 20);
  EXPECT_LT(report["map"]["memory_budget_bytes"].get<int64_t>(), int64_t{20} << 20);
  EXPECT_LT(report["map"]["batch_points"].get<int64_t>(), 2'000'000);

  // Occupied and free cells at the finest depth (a pruned leaf of depth d
  // stands for 8^(16 - d) of them).
  auto count = [](const octomap::OcTree& tree, int64_t* occupied, int64_t* free) {
    for (auto it = tree.begin_leafs(), end = tree.end_leafs(); it != end; ++it) {
      const int64_t cells = int64_t{1} << (3 * (tree.getTreeDepth() - it.getDepth()));
      (tree.isNodeOccupied(*it) ? *occupied : *free) += cells;
    }
  };
  octomap::OcTree whole(0.1);
  ASSERT_TRUE(whole.readBinary((dir_ / "big" / "map.bt").string()));
  int64_t whole_occupied = 0, whole_free = 0;
  count(whole, &whole_occupied, &whole_free);
  const nlohmann::json index =
      nlohmann::json::parse(ReadFile(dir_ / "small" / "map.tiles" / "index.json"));
  ASSERT_GT(index["tiles"].size(), 1u);
  int64_t occupied = 0, free = 0;
  for (const nlohmann::json& tile : index["tiles"]) {
    octomap::OcTree tree(0.1);
    ASSERT_TRUE(tree.readBinary(
        (dir_ / "small" / "map.tiles" / tile["file"].get<std::string>()).string()));
    count(tree, &occupied, &free);
  }
  EXPECT_GT(whole_occupied, 1000);
  EXPECT_EQ(occupied, whole_occupied);
  EXPECT_EQ(free, whole_free);
}

// A run tied to nothing is in its own frame: it gets a map of its own
// (map_c1.*), and the main map holds only the tied runs' scans.
TEST_F(JobMap, ARunTiedToNothingIsMappedOnItsOwn) {
  ASSERT_TRUE(Run("output: out\nthreads: 2\n"
                  "map: {resolution: 0.3, max_range: 20}\n"
                  "runs:\n"
                  "  - name: campus\n"
                  "    format: simulate\n"
                  "    simulate: {poses: 300, runs: 2, gps_every: 10, seed: 4, scans: true,\n"
                  "               scan_beams: 30, scan_max_range: 20}\n"
                  "  - name: lonely\n"
                  "    format: simulate\n"
                  "    simulate: {poses: 150, seed: 5, feature_id_base: 5000000, scans: true,\n"
                  "               scan_beams: 30, scan_max_range: 20}\n")
                  .ok());
  const fs::path out = dir_ / "out";
  StatusOr<map::PcdContents> main = map::ReadPcd((out / "map.pcd").string());
  StatusOr<map::PcdContents> lonely = map::ReadPcd((out / "map_c1.pcd").string());
  ASSERT_TRUE(main.ok()) << main.status().ToString();
  ASSERT_TRUE(lonely.ok()) << lonely.status().ToString();
  EXPECT_EQ(std::set<float>(main->run.begin(), main->run.end()), (std::set<float>{0.0f, 1.0f}));
  EXPECT_EQ(std::set<float>(lonely->run.begin(), lonely->run.end()), (std::set<float>{2.0f}));
  // Run index 2 of map_c1.pcd is "lonely": one index space for all maps.
  StatusOr<std::vector<std::string>> names =
      storage::ReadPcdRunNames((out / "map_c1.pcd").string());
  ASSERT_TRUE(names.ok()) << names.status().ToString();
  EXPECT_EQ(*names, (std::vector<std::string>{"campus_1", "campus_2", "lonely"}));
  octomap::OcTree tree(0.1);
  EXPECT_TRUE(tree.readBinary((out / "map_c1.bt").string()));
  const nlohmann::json report = nlohmann::json::parse(ReadFile(out / "report.json"));
  EXPECT_EQ(report["map"]["files"],
            nlohmann::json({"map.bt", "map.pcd", "map_c1.bt", "map_c1.pcd"}));
  ASSERT_EQ(report["map"]["maps"].size(), 2u);
  EXPECT_EQ(report["map"]["maps"][0]["scans"].get<int64_t>(), 300);
  EXPECT_EQ(report["map"]["maps"][1]["scans"].get<int64_t>(), 150);
  EXPECT_EQ(report["map"]["maps"][1]["runs"], nlohmann::json({"lonely"}));
}

// A run's `scans:` folder (a scan store whose scans' pose is the index within
// the run) is fused like generated scans: the same map, byte for byte.
TEST_F(JobMap, AScanFolderOfARunIsFusedAtItsOptimizedPoses) {
  const std::string simulate = "    simulate: {poses: 200, gps_every: 10, seed: 6";
  ASSERT_TRUE(Run("output: generated\nmap: {resolution: 0.3, max_range: 20}\nruns:\n"
                  "  - name: solo\n    format: simulate\n" +
                  simulate + ", scans: true, scan_beams: 30, scan_max_range: 20}\n")
                  .ok());
  fs::copy(dir_ / "generated" / ".job" / "scans" / "solo", dir_ / "folder",
           fs::copy_options::recursive);
  ASSERT_TRUE(Run("output: given\nmap: {resolution: 0.3, max_range: 20}\nruns:\n"
                  "  - name: solo\n    format: simulate\n    scans: folder\n" +
                  simulate + "}\n")
                  .ok());
  EXPECT_FALSE(fs::exists(dir_ / "given" / ".job" / "scans"));
  ASSERT_TRUE(fs::exists(dir_ / "given" / "map.bt"));
  EXPECT_EQ(ReadFile(dir_ / "given" / "map.bt"), ReadFile(dir_ / "generated" / "map.bt"));
  EXPECT_EQ(ReadFile(dir_ / "given" / "map.pcd"), ReadFile(dir_ / "generated" / "map.pcd"));
  // A folder that is not a scan store: an error naming the job file's line.
  const Status missing = Run("output: bad\nruns:\n  - name: solo\n    format: simulate\n"
                             "    scans: nowhere\n" + simulate + "}\n");
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.message().find("job.yaml:3: run 'solo' scans:"), std::string::npos)
      << missing.message();
}

// A native log whose SCAN records name .pcd files: the job copies the scans
// at ingest (.job/scans/<run>/) and maps them without the log or the .pcd
// files; the map equals the one of the same run given the scan store that
// `graphslam ingest` makes of the log (scans: folder).
TEST_F(JobMap, TheScansOfANativeLogAreCopiedAtIngestAndMappedFromTheCopy) {
  {
    std::ofstream log(dir_ / "run.log");
    log << "GRAPHSLAM_LOG 1\n";
    fs::create_directories(dir_ / "pcd");
    for (int i = 0; i < 12; ++i) {
      log << "POSE " << i << " " << i << " " << 0.5 * i << " 0 0\n";
      if (i == 0) log << "FIX 0\n";
      if (i > 0) log << "ODOM " << i - 1 << " " << i << " 0.5 0 0 100 0 0 100 0 100\n";
      for (int f = 0; f < 4; ++f) {
        const double dx = 2.0 * f - 0.5 * i, dy = 3.0;
        log << "RB " << i << " " << f << " " << std::hypot(dx, dy) << " " << std::atan2(dy, dx)
            << " 100 0 400\n";
      }
      // A wall 3 m to the left, by hand in PCL's ASCII format.
      std::ofstream pcd(dir_ / "pcd" / (std::to_string(i) + ".pcd"));
      pcd << "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 60\n"
             "HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 60\nDATA ascii\n";
      for (int k = 0; k < 60; ++k) pcd << 0.1 * (k % 10) << " 3 " << 0.2 * (k / 10) << "\n";
      log << "SCAN " << i << " pcd/" << i << ".pcd\n";
    }
  }
  partition::StreamingIngestOptions ingest;
  partition::IngestSummary summary;
  ASSERT_TRUE(partition::IngestToStore(storage::Env::Default(), (dir_ / "run.log").string(),
                                       (dir_ / "store").string(), ingest, &summary)
                  .ok());
  ASSERT_EQ(summary.scans.scans, 12);
  const std::string map = "map: {resolution: 0.3, max_range: 20}\n";
  ASSERT_TRUE(Run("output: copied\n" + map + "runs:\n  - name: solo\n    format: native\n"
                  "    path: run.log\n")
                  .ok());
  EXPECT_TRUE(map::DiskScanStore::Exists((dir_ / "copied" / ".job" / "scans" / "solo").string()));
  fs::remove_all(dir_ / "pcd");
  ASSERT_TRUE(Run("output: given\n" + map + "runs:\n  - name: solo\n    format: native\n"
                  "    path: run.log\n    scans: store\n")
                  .ok());
  ASSERT_TRUE(fs::exists(dir_ / "copied" / "map.bt"));
  EXPECT_EQ(ReadFile(dir_ / "copied" / "map.bt"), ReadFile(dir_ / "given" / "map.bt"));
  EXPECT_EQ(ReadFile(dir_ / "copied" / "map.pcd"), ReadFile(dir_ / "given" / "map.pcd"));
  StatusOr<map::PcdContents> cloud = map::ReadPcd((dir_ / "copied" / "map.pcd").string());
  ASSERT_TRUE(cloud.ok()) << cloud.status().ToString();
  EXPECT_GT(cloud->points.size(), 30u);
}

TEST_F(JobMap, ScanChunksFollowTheMemoryLimit) {
  EXPECT_EQ(ScanChunkBytes(0), int64_t{16} << 20);
  EXPECT_EQ(ScanChunkBytes(int64_t{64} << 20), int64_t{1} << 20);
  EXPECT_EQ(ScanChunkBytes(int64_t{1} << 20), int64_t{256} << 10);
  EXPECT_EQ(ScanChunkBytes(int64_t{64} << 30), int64_t{16} << 20);
}

TEST_F(JobMap, BadMapSettingsAreErrorsWithTheLine) {
  const Status status = Run(
      "output: out\n"
      "map: {resolution: 0}\n"
      "runs:\n"
      "  - {name: a, format: simulate}\n");
  ASSERT_FALSE(status.ok());
  EXPECT_NE(status.message().find("job.yaml:2:"), std::string::npos) << status.message();
  const Status beams = Run(
      "output: out\n"
      "runs:\n"
      "  - name: a\n"
      "    format: simulate\n"
      "    simulate: {scans: true, scan_beams: 0}\n");
  ASSERT_FALSE(beams.ok());
  EXPECT_NE(beams.message().find("job.yaml:5:"), std::string::npos) << beams.message();
}

}  // namespace
}  // namespace graphslam::tools::job
