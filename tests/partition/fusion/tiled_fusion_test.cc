// TiledFusion must give exactly OctoMap's serial insertPointCloud: the same
// leaves (key, depth) with the same log-odds, hence the same occupied set.
#include "partition/fusion/tiled_fusion.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <random>
#include <tuple>

#include "core/scan.h"
#include "storage/threedtk_reader.h"
#include "tests/testing/datasets.h"

namespace graphslam::map {
namespace {

using LeafKey = std::tuple<uint16_t, uint16_t, uint16_t, unsigned>;

std::map<LeafKey, float> Leaves(octomap::OcTree* tree) {
  tree->prune();
  std::map<LeafKey, float> leaves;
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
    const octomap::OcTreeKey k = it.getKey();
    leaves[{k[0], k[1], k[2], it.getDepth()}] = it->getLogOdds();
  }
  return leaves;
}

std::set<LeafKey> Occupied(octomap::OcTree* tree) {
  std::set<LeafKey> occupied;
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
    if (tree->isNodeOccupied(*it)) {
      const octomap::OcTreeKey k = it.getKey();
      occupied.insert({k[0], k[1], k[2], it.getDepth()});
    }
  }
  return occupied;
}

// Scans from a few origins inside a 12 m x 8 m x 3 m room (walls, floor,
// ceiling), with some rays through a 2 m doorway in the +x wall that end 6 m
// outside (beyond a 9 m max range for the far ones).
std::vector<WorldScan> RoomScans(int scans, int points_per_scan, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<WorldScan> out;
  for (int s = 0; s < scans; ++s) {
    WorldScan scan;
    scan.origin = Eigen::Vector3f(-4.0f + 1.3f * static_cast<float>(s % 6), 0.5f * u(rng), 1.2f);
    for (int i = 0; i < points_per_scan; ++i) {
      Eigen::Vector3f d(u(rng), u(rng), 0.6f * u(rng));
      if (d.norm() < 1e-3f) continue;
      d.normalize();
      // Distance to the room's boundary along d.
      float t = 1e9f;
      const Eigen::Vector3f lo(-6.0f, -4.0f, 0.0f), hi(6.0f, 4.0f, 3.0f);
      for (int a = 0; a < 3; ++a) {
        if (d[a] > 1e-6f) t = std::min(t, (hi[a] - scan.origin[a]) / d[a]);
        if (d[a] < -1e-6f) t = std::min(t, (lo[a] - scan.origin[a]) / d[a]);
      }
      Eigen::Vector3f p = scan.origin + t * d;
      if (p.x() > 5.99f && std::abs(p.y()) < 1.0f && p.z() < 2.0f) p = scan.origin + (t + 6.0f) * d;
      scan.points.push_back(p);
    }
    out.push_back(std::move(scan));
  }
  return out;
}

void ExpectSameAsSerial(const FusionOptions& options, const std::vector<WorldScan>& scans,
                        size_t batch, size_t spill_budget = 0) {
  std::unique_ptr<octomap::OcTree> serial = FuseSerial(options, scans);
  TiledFusion fusion(options);
  if (spill_budget > 0) {
    const std::string dir = ::testing::TempDir() + "/tiled_fusion_spill";
    std::filesystem::create_directories(dir);
    fusion.EnableSpill(dir, spill_budget);
  }
  for (size_t i = 0; i < scans.size(); i += batch) {
    ASSERT_TRUE(fusion
                    .Insert(std::vector<WorldScan>(
                        scans.begin() + static_cast<std::ptrdiff_t>(i),
                        scans.begin() + static_cast<std::ptrdiff_t>(std::min(scans.size(), i + batch))))
                    .ok());
  }
  EXPECT_GT(fusion.num_tiles(), 1u);
  if (spill_budget > 0) {
    EXPECT_GT(fusion.spills(), 0);
  }
  StatusOr<std::unique_ptr<octomap::OcTree>> merged = fusion.Merge();
  ASSERT_TRUE(merged.ok()) << merged.status().ToString();
  std::unique_ptr<octomap::OcTree> tiled = std::move(merged).value();
  const std::set<LeafKey> occupied_serial = Occupied(serial.get());
  EXPECT_GT(occupied_serial.size(), 100u);
  EXPECT_EQ(Occupied(tiled.get()), occupied_serial);
  const std::map<LeafKey, float> a = Leaves(serial.get()), b = Leaves(tiled.get());
  ASSERT_EQ(a.size(), b.size());
  size_t differing = 0;
  for (const auto& [key, value] : a) {
    auto it = b.find(key);
    if (it == b.end() || it->second != value) ++differing;
  }
  EXPECT_EQ(differing, 0u);
  EXPECT_EQ(serial->size(), tiled->size());
}

TEST(TiledFusionTest, RoomEqualsSerialInsertPointCloud) {
  FusionOptions options;
  options.resolution = 0.1;
  options.tile_bits = 5;  // 3.2 m tiles: rays cross many
  // Twelve scans, each origin twice, so cells reach the clamping bounds.
  ExpectSameAsSerial(options, RoomScans(12, 1500, 7), 5);
}

TEST(TiledFusionTest, MaxRangeAndCoarseTilesEqualSerial) {
  FusionOptions options;
  options.resolution = 0.2;
  options.max_range = 9.0;
  options.tile_bits = 3;
  options.prob_hit = 0.9;  // reaches the clamp sooner
  ExpectSameAsSerial(options, RoomScans(10, 2000, 11), 3);
}

TEST(TiledFusionTest, SpillingTilesToDiskEqualsSerial) {
  FusionOptions options;
  options.resolution = 0.1;
  options.tile_bits = 5;
  // A tiny budget: after every 2-scan batch most tiles go to disk and come
  // back when touched again.
  ExpectSameAsSerial(options, RoomScans(8, 800, 3), 2, /*spill_budget=*/20000);
}

// Within a budget, the fusion's accounted memory (resident tiles at their
// high water before pruning, plus the codes of the scans being fused) never
// passes it, and the map is still the serial one. The budget is a third of
// the map (so tiles must be spilled and read back), and at least four times
// the biggest tile (so one group always fits).
TEST(TiledFusionTest, AccountedMemoryStaysWithinBudget) {
  FusionOptions options;
  options.resolution = 0.1;
  options.tile_bits = 5;
  const std::vector<WorldScan> scans = RoomScans(12, 1500, 7);
  TiledFusion unbounded(options);
  ASSERT_TRUE(unbounded.Insert(scans).ok());
  const size_t map_bytes = unbounded.MemoryUsage();
  const size_t budget = std::max(map_bytes / 3, 4 * unbounded.memory_stats().max_tile_bytes);
  ASSERT_LT(budget, map_bytes);

  TiledFusion fusion(options);
  const std::string dir = ::testing::TempDir() + "/tiled_fusion_budget";
  std::filesystem::create_directories(dir);
  fusion.EnableSpill(dir, budget);
  for (size_t i = 0; i < scans.size(); i += 6) {
    ASSERT_TRUE(fusion.Insert(std::vector<WorldScan>(scans.begin() + static_cast<std::ptrdiff_t>(i),
                                                     scans.begin() + static_cast<std::ptrdiff_t>(i + 6)))
                    .ok());
  }
  const TiledFusion::MemoryStats& stats = fusion.memory_stats();
  EXPECT_GT(fusion.spills(), 0);
  EXPECT_GT(stats.groups, 2);  // the touched tiles did not fit at once
  EXPECT_LE(stats.peak_accounted_bytes, budget);
  EXPECT_GT(stats.peak_accounted_bytes, budget / 2);  // the budget was used, not shunned
  EXPECT_GT(stats.peak_code_bytes, 0u);
  EXPECT_LE(stats.peak_code_bytes, budget / 4);
  EXPECT_EQ(fusion.MemoryUsage(), map_bytes);

  StatusOr<std::unique_ptr<octomap::OcTree>> merged = fusion.Merge();
  ASSERT_TRUE(merged.ok()) << merged.status().ToString();
  std::unique_ptr<octomap::OcTree> serial = FuseSerial(options, scans);
  const std::map<LeafKey, float> a = Leaves(serial.get()), b = Leaves(merged->get());
  EXPECT_GT(a.size(), 1000u);
  EXPECT_EQ(a, b);
  std::printf("map %zu B, budget %zu B, peak accounted %zu B, codes %zu B, groups %lld, "
              "spills %lld, growth/code %.1f B\n",
              map_bytes, budget, stats.peak_accounted_bytes, stats.peak_code_bytes,
              static_cast<long long>(stats.groups), static_cast<long long>(fusion.spills()),
              stats.max_growth_per_code);
}

TEST(TiledFusionTest, ThreeDtkScansEqualSerial) {
  GS_REQUIRE_DATASET("3dtk_uos_scans/scan000.3d");
  const std::string dir = testing::DatasetPath("3dtk_uos_scans");
  std::vector<WorldScan> scans;
  for (int n = 0; n < 3; ++n) {
    StatusOr<Scan> scan = Read3dtkScan(dir, n, n);
    ASSERT_TRUE(scan.ok()) << scan.status().ToString();
    WorldScan world;
    world.origin = scan->sensor_pose.t.cast<float>();
    const std::vector<Eigen::Vector3f> points = WorldPoints(*scan);
    for (size_t i = 0; i < points.size(); i += 8) world.points.push_back(points[i]);
    scans.push_back(std::move(world));
  }
  FusionOptions options;
  options.resolution = 0.25;
  options.max_range = 15.0;
  options.tile_bits = 5;
  ExpectSameAsSerial(options, scans, 2);
}

TEST(TiledFusionTest, ValidateRejectsBadOptions) {
  FusionOptions options;
  options.resolution = 0.0;
  EXPECT_FALSE(options.Validate().ok());
  options = FusionOptions();
  options.tile_bits = 16;
  EXPECT_FALSE(options.Validate().ok());
  EXPECT_TRUE(FusionOptions().Validate().ok());
}

}  // namespace
}  // namespace graphslam::map
