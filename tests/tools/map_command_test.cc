// `graphslam simulate --3d --scans` then `graphslam map`: the .bt and .pcd
// read back with OctoMap's and PCL's own readers, walls of the simulated
// campus are occupied and its street space free; the 3DTK scans fuse; over
// the memory budget the map is written as tiles + index.json.
#include "tools/map_command.h"

#include <gtest/gtest.h>
#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <tuple>

#include "tools/campus_3d.h"
#include "storage/pcd_io.h"
#include "tests/testing/datasets.h"
#include "tools/exit_codes.h"
#include "tools/simulate_command.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

fs::path ScratchPath() {
  const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return fs::temp_directory_path() /
         ("graphslam_map_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
}

class MapCommandTest : public ::testing::Test {
 protected:
  void SetUp() override { fs::remove_all(root_); }
  void TearDown() override { fs::remove_all(root_); }
  const fs::path root_ = ScratchPath();
};

map::Campus3dOptions SmallCampus() {
  map::Campus3dOptions c;
  c.columns = 2;
  c.rows = 2;
  c.block_size = 30.0;
  c.pose_spacing = 1.0;
  c.beams = 360;
  c.max_range = 30.0;
  // Faces at 6.25 m from the centrelines: no fan plane (every 1 m) grazes
  // them inside a wall cell (a ray 3 cm outside a wall clears the wall's cell,
  // in OctoMap's discretization as in ours).
  c.street_width = 12.5;
  return c;
}

std::unique_ptr<octomap::OcTree> ReadBt(const std::string& path) {
  // AbstractOcTree::read dispatches on the file's tree type (here a .bt is
  // read through OcTree(filename), OctoMap's binary reader).
  auto tree = std::make_unique<octomap::OcTree>(path);
  return tree;
}

TEST_F(MapCommandTest, SimulatedCampusWallsOccupiedStreetsFree) {
  SimulateCommandOptions sim;
  sim.output_dir = (root_ / "campus").string();
  sim.sim3d.enabled = true;
  sim.sim3d.scans = true;
  sim.sim3d.campus = SmallCampus();
  sim.simulator.seed = 4;
  sim.quiet = true;
  ASSERT_EQ(RunSimulateCommand(sim), kExitOk);
  ASSERT_TRUE(fs::exists(root_ / "campus" / "scans" / "SCANS.json"));
  ASSERT_TRUE(fs::exists(root_ / "campus" / "ground_truth_3d.tum"));

  MapCommandOptions options;
  options.input = sim.output_dir;
  options.poses_path = (root_ / "campus" / "ground_truth_3d.tum").string();
  options.map.bt_path = (root_ / "campus.bt").string();
  options.map.pcd_path = (root_ / "campus.pcd").string();
  options.map.fusion.resolution = 0.1;
  options.quiet = true;
  ASSERT_EQ(RunMapCommand(options), kExitOk);

  // OctoMap's own reader.
  std::unique_ptr<octomap::OcTree> tree = ReadBt(options.map.bt_path);
  ASSERT_GT(tree->size(), 1000u);
  EXPECT_DOUBLE_EQ(tree->getResolution(), 0.1);
  map::Campus3dOptions c = SmallCampus();
  c.seed = 4;
  const map::Campus3d campus = map::MakeCampus3d(c);
  // Street: the air the laser saw over the row streets: points along the
  // beams of the row-street poses, |lateral| <= 3 m, 0.3 m to 2.5 m above the
  // ground, at least 0.3 m short of the beam's hit.
  std::vector<core::Pose3> poses;
  std::vector<int32_t> runs;
  map::Campus3dTrajectory(campus, &poses, &runs);
  // Walls: where a beam of a row-street pose hits a building face along the
  // street, the cell 2 cm inside the face is occupied.
  int street_known = 0, street_free = 0, street_samples = 0;
  int wall_samples = 0, wall_occupied = 0;
  for (size_t k = 0; k < poses.size(); k += 3) {
    const Eigen::Matrix3d r = poses[k].rotation();
    if (std::abs(r(0, 0)) < 0.9) continue;  // a column street
    for (int beam = 0; beam < c.beams; beam += 5) {
      const double angle = 2.0 * 3.14159265358979323846 * (beam + 0.5) / c.beams;
      const Eigen::Vector3d d = r * Eigen::Vector3d(0.0, std::cos(angle), std::sin(angle));
      const double hit = campus.Cast(poses[k].t, d, c.max_range);
      if (!std::isfinite(hit)) continue;
      const Eigen::Vector3d end = poses[k].t + hit * d;
      for (const map::Box& b : campus.buildings) {
        for (double face : {b.lo.y(), b.hi.y()}) {
          if (std::abs(end.y() - face) > 1e-6 || end.x() < b.lo.x() + 0.2 ||
              end.x() > b.hi.x() - 0.2 || end.z() > b.hi.z() - 0.2) {
            continue;
          }
          const double inside = face == b.lo.y() ? 0.02 : -0.02;
          ++wall_samples;
          const octomap::OcTreeNode* node = tree->search(end.x(), end.y() + inside, end.z());
          if (node != nullptr && tree->isNodeOccupied(node)) ++wall_occupied;
        }
      }
      for (double s = 0.2; s < hit - 0.3; s += 0.2) {
        const Eigen::Vector3d p = poses[k].t + s * d;
        const double lateral = p.y() - std::round(p.y() / c.block_size) * c.block_size;
        const double above = p.z() - campus.GroundZ(p.x(), p.y());
        if (std::abs(lateral) > 3.0 || above < 0.3 || above > 2.5) continue;
        ++street_samples;
        const octomap::OcTreeNode* node = tree->search(p.x(), p.y(), p.z());
        if (node == nullptr) continue;
        ++street_known;
        if (!tree->isNodeOccupied(node)) ++street_free;
      }
    }
  }
  ASSERT_GT(wall_samples, 300);
  EXPECT_GE(wall_occupied, 0.99 * wall_samples) << wall_occupied << " of " << wall_samples;
  ASSERT_GT(street_samples, 1000);
  EXPECT_EQ(street_known, street_samples);
  EXPECT_GE(street_free, 0.99 * street_known) << street_free << " of " << street_known;

  // PCL's own reader: binary_compressed, with the run field, inside the campus.
  StatusOr<map::PcdContents> cloud = map::ReadPcd(options.map.pcd_path);
  ASSERT_TRUE(cloud.ok()) << cloud.status().ToString();
  EXPECT_EQ(cloud->data_type, "binary_compressed");
  ASSERT_GT(cloud->points.size(), 1000u);
  ASSERT_EQ(cloud->run.size(), cloud->points.size());
  EXPECT_TRUE(cloud->intensity.empty());
  std::set<float> cloud_runs(cloud->run.begin(), cloud->run.end());
  EXPECT_EQ(cloud_runs, (std::set<float>{0.0f, 1.0f}));
  for (const Eigen::Vector3f& p : cloud->points) {
    ASSERT_GT(p.x(), -c.max_range);
    ASSERT_LT(p.x(), c.columns * c.block_size + c.max_range);
    ASSERT_GT(p.z(), -2.0f);
    ASSERT_LT(p.z(), 25.0f);
  }
}

TEST_F(MapCommandTest, ThreeDtkScansFuseThroughTheBinary) {
  GS_REQUIRE_DATASET("3dtk_uos_scans/scan000.3d");
  const std::string bt = (root_ / "uos.bt").string(), pcd = (root_ / "uos.pcd").string();
  fs::create_directories(root_);
  const std::string command = ::graphslam::testing::BinaryDir() + "/bin/graphslam map " +
                              testing::DatasetPath("3dtk_uos_scans") + " --bt " + bt + " --pcd " +
                              pcd + " --resolution 0.2 --max-range 12 -q";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::unique_ptr<octomap::OcTree> fused = ReadBt(bt);
  // Each scan alone, in its pose: the fused map's occupied cells overlap
  // (registered scans of one place), so there are fewer than the sum.
  std::set<std::tuple<int, int, int>> occupied_fused;
  for (auto it = fused->begin_leafs(fused->getTreeDepth()); it != fused->end_leafs(); ++it) {
    if (fused->isNodeOccupied(*it)) {
      const octomap::OcTreeKey k = it.getKey();
      occupied_fused.insert({k[0], k[1], k[2]});
    }
  }
  ASSERT_GT(occupied_fused.size(), 5000u);
  StatusOr<std::unique_ptr<map::ScanSource>> source =
      OpenScanSource(testing::DatasetPath("3dtk_uos_scans"));
  ASSERT_TRUE(source.ok());
  ASSERT_EQ((*source)->NumChunks(), 3);
  // Scan 2's endpoints (within 12 m of its origin) mostly land in cells that
  // are occupied in the fused map.
  std::vector<map::Scan> scans;
  ASSERT_TRUE((*source)->Load(2, &scans).ok());
  int inside = 0, hits = 0;
  const std::vector<Eigen::Vector3f> world = map::WorldPoints(scans[0]);
  for (size_t i = 0; i < world.size(); i += 7) {
    if ((world[i].cast<double>() - scans[0].sensor_pose.t).norm() > 11.5) continue;
    ++inside;
    const octomap::OcTreeNode* node = fused->search(world[i].x(), world[i].y(), world[i].z());
    if (node != nullptr && fused->isNodeOccupied(node)) ++hits;
  }
  ASSERT_GT(inside, 1000);
  EXPECT_GT(hits, 0.9 * inside) << hits << " of " << inside;

  StatusOr<map::PcdContents> cloud = map::ReadPcd(pcd);
  ASSERT_TRUE(cloud.ok()) << cloud.status().ToString();
  EXPECT_EQ(cloud->data_type, "binary_compressed");
  EXPECT_GT(cloud->points.size(), 10000u);
  EXPECT_TRUE(cloud->run.empty());
}

TEST_F(MapCommandTest, OverBudgetWritesTilesWhoseUnionIsTheMap) {
  GS_REQUIRE_DATASET("3dtk_uos_scans/scan000.3d");
  MapCommandOptions options;
  options.input = testing::DatasetPath("3dtk_uos_scans");
  options.map.fusion.resolution = 0.3;
  options.map.fusion.max_range = 8.0;
  options.map.fusion.tile_bits = 6;
  options.quiet = true;
  options.map.bt_path = (root_ / "whole.bt").string();
  fs::create_directories(root_);
  ASSERT_EQ(RunMapCommand(options), kExitOk);
  std::unique_ptr<octomap::OcTree> whole = ReadBt(options.map.bt_path);
  options.map.bt_path = (root_ / "tiled.bt").string();
  options.memory_budget_mib = 0.01;
  ASSERT_EQ(RunMapCommand(options), kExitOk);
  EXPECT_FALSE(fs::exists(root_ / "tiled.bt"));
  std::ifstream in(root_ / "tiled.tiles" / "index.json");
  ASSERT_TRUE(in.good());
  const nlohmann::json index = nlohmann::json::parse(in);
  ASSERT_GT(index.at("tiles").size(), 1u);
  using Cell = std::tuple<int, int, int>;
  auto occupied_cells = [](octomap::OcTree* t, std::set<Cell>* out) {
    for (auto it = t->begin_leafs(t->getTreeDepth()); it != t->end_leafs(); ++it) {
      if (t->isNodeOccupied(*it)) out->insert({it.getKey()[0], it.getKey()[1], it.getKey()[2]});
    }
  };
  std::set<Cell> from_tiles, from_whole;
  for (const nlohmann::json& tile : index.at("tiles")) {
    std::unique_ptr<octomap::OcTree> t =
        ReadBt((root_ / "tiled.tiles" / tile.at("file").get<std::string>()).string());
    occupied_cells(t.get(), &from_tiles);
  }
  occupied_cells(whole.get(), &from_whole);
  EXPECT_GT(from_whole.size(), 1000u);
  EXPECT_EQ(from_tiles, from_whole);
}

// The registered cloud within a pcd memory budget: a 50 kB budget spills the
// voxel tiles to OUT.voxels/ (removed afterwards) and writes the bytes of an
// unbounded run (storage/tiled_voxel_cloud.h).
TEST_F(MapCommandTest, TheCloudWithinATinyBudgetIsTheUnboundedCloud) {
  GS_REQUIRE_DATASET("3dtk_uos_scans/scan000.3d");
  MapCommandOptions options;
  options.input = testing::DatasetPath("3dtk_uos_scans");
  options.map.fusion.resolution = 0.2;
  options.map.fusion.tile_bits = 5;
  options.quiet = true;
  fs::create_directories(root_);
  options.map.pcd_path = (root_ / "unbounded.pcd").string();
  ASSERT_EQ(RunMapCommand(options), kExitOk);
  // The library entry point, to see the spills.
  StatusOr<std::unique_ptr<map::ScanSource>> source = OpenScanSource(options.input);
  ASSERT_TRUE(source.ok());
  map::MapOptions tiny_options = options.map;
  tiny_options.pcd_path = (root_ / "tiny.pcd").string();
  tiny_options.pcd_memory_bytes = 50'000;
  StatusOr<map::MapSummary> summary = map::BuildMap(tiny_options, **source, nullptr);
  ASSERT_TRUE(summary.ok()) << summary.status().ToString();
  EXPECT_GT(summary->pcd_tile_spills, 10);
  // No .bt: nothing fused, so no fusion time and no rate (it used to be
  // points over the ~0 s of empty flushes).
  EXPECT_EQ(summary->fusion_seconds, 0.0);
  EXPECT_EQ(summary->points_per_second, 0.0);
  EXPECT_EQ(summary->tiles, 0);
  EXPECT_FALSE(fs::exists(root_ / "tiny.voxels"));
  StatusOr<map::PcdContents> tiny = map::ReadPcd((root_ / "tiny.pcd").string());
  ASSERT_TRUE(tiny.ok()) << tiny.status().ToString();
  EXPECT_EQ(static_cast<int64_t>(tiny->points.size()), summary->pcd_points);
  EXPECT_GT(tiny->points.size(), 10000u);
  std::ifstream a(root_ / "tiny.pcd", std::ios::binary), b(root_ / "unbounded.pcd", std::ios::binary);
  const std::string tiny_bytes((std::istreambuf_iterator<char>(a)), std::istreambuf_iterator<char>());
  const std::string unbounded_bytes((std::istreambuf_iterator<char>(b)), std::istreambuf_iterator<char>());
  EXPECT_TRUE(tiny_bytes == unbounded_bytes);
}

TEST_F(MapCommandTest, BadInputsExitNonZero) {
  // The output folder exists: a missing one is found first (exit 3, before
  // any input is read; early_checks_test).
  fs::create_directories(root_);
  MapCommandOptions options;
  options.input = (root_ / "missing").string();
  options.map.bt_path = (root_ / "x.bt").string();
  options.quiet = true;
  EXPECT_EQ(RunMapCommand(options), kExitBadInput);
  options.input = testing::DatasetPath("3dtk_uos_scans");
  options.map.fusion.resolution = -1;
  EXPECT_EQ(RunMapCommand(options), kExitUsage);
  fs::create_directories(root_);
  std::ofstream(root_ / "bad.tum") << "0 1 2 3 0 0 0 1\n0 1 2\n";
  StatusOr<std::vector<core::Pose3>> poses = ReadTumPoses((root_ / "bad.tum").string());
  ASSERT_FALSE(poses.ok());
  EXPECT_NE(poses.status().ToString().find("bad.tum:2"), std::string::npos);
}

}  // namespace
}  // namespace graphslam::tools
