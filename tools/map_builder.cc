#include "tools/map_builder.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>
#include <system_error>

#include "storage/pcd_io.h"
#include "storage/tiled_voxel_cloud.h"
#include "storage/atomic_file.h"
#include "storage/env.h"
#include "storage/stop_point.h"

namespace graphslam::map {
namespace {

constexpr int64_t kProcessReserve = int64_t{64} << 20;

// The .bt header that OcTree::readBinary (octovis, binvox2bt) expects, then the node bits.
// Written here rather than by writeBinaryConst, which Debian's liboctomap (built with its
// debug output on) follows with a " done." line on stderr that `-q` cannot silence.
Status WriteTree(const octomap::OcTree& tree, const std::string& path) {
  std::ostringstream stream;
  stream << "# Octomap OcTree binary file\n#\n"
         << "id " << tree.getTreeType() << "\n"
         << "size " << tree.size() << "\n"
         << "res " << tree.getResolution() << "\n"
         << "data\n";
  tree.writeBinaryData(stream);
  if (!stream.good()) return Status::IOError("writing " + path + ": OctoMap failed");
  return storage::WriteStringAtomically(storage::Env::Default(), path, stream.str());
}

std::string TilesDir(const std::string& bt_path) {
  std::filesystem::path p(bt_path);
  p.replace_extension("");
  return p.string() + ".tiles";
}

}  // namespace

Status MapOptions::Validate() const {
  GS_RETURN_IF_ERROR(fusion.Validate());
  if (bt_path.empty() && pcd_path.empty()) {
    return Status::InvalidArgument("nothing to write: give a .bt and/or a .pcd path");
  }
  if (!std::isfinite(pcd_voxel)) return Status::InvalidArgument("pcd voxel must be finite");
  if (memory_budget_bytes <= 0) return Status::InvalidArgument("memory budget must be > 0");
  if (batch_points <= 0) return Status::InvalidArgument("batch points must be > 0");
  if (pcd_memory_bytes < 0) return Status::InvalidArgument("pcd memory must be >= 0");
  return Status::Ok();
}

StatusOr<MapSummary> BuildMap(const MapOptions& options, const ScanSource& scans,
                              const std::vector<core::Pose3>* poses) {
  GS_RETURN_IF_ERROR(options.Validate());
  MapSummary summary;
  TiledFusion fusion(options.fusion);
  const bool fuse = !options.bt_path.empty();
  TiledVoxelCloudOptions cloud_options;
  cloud_options.voxel = options.pcd_voxel > 0.0 ? options.pcd_voxel : options.fusion.resolution;
  cloud_options.tile_bits = options.fusion.tile_bits;
  cloud_options.budget_bytes =
      options.pcd_memory_bytes > 0 ? options.pcd_memory_bytes : options.memory_budget_bytes / 4;
  if (fuse) {
    // The fusion gets what the cloud and the rest of the process leave of
    // the budget, at least a sixteenth of it. The rest is kProcessReserve:
    // code and libraries, one chunk of scans, one batch of world points, the
    // per-thread buffers of ray casting (docs/tuning.md).
    const int64_t reserve = std::min(kProcessReserve, options.memory_budget_bytes / 8);
    int64_t fusion_bytes = options.memory_budget_bytes - reserve;
    if (!options.pcd_path.empty()) fusion_bytes -= cloud_options.budget_bytes;
    fusion_bytes = std::max(fusion_bytes, options.memory_budget_bytes / 16);
    std::filesystem::path spill(options.bt_path);
    spill.replace_extension(".spill");
    fusion.EnableSpill(spill.string(), static_cast<size_t>(fusion_bytes));
  }
  std::optional<TiledVoxelCloud> cloud;  // only with a .pcd: it owns OUT.voxels/
  if (!options.pcd_path.empty()) {
    std::filesystem::path voxels(options.pcd_path);
    voxels.replace_extension(".voxels");
    cloud_options.spill_dir = voxels.string();
    cloud.emplace(cloud_options);
  }
  std::vector<WorldScan> batch;
  int64_t batch_points = 0;
  double seconds = 0.0;
  int64_t batches = 0;
  auto flush = [&]() -> Status {
    if (fuse) {  // without a .bt nothing is fused, and no time is counted
      const auto start = std::chrono::steady_clock::now();
      GS_RETURN_IF_ERROR(fusion.Insert(batch));
      seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      storage::StopPointForTests("map_batch " + std::to_string(++batches));
    }
    batch.clear();
    batch_points = 0;
    return Status::Ok();
  };
  std::vector<Scan> chunk;
  for (int64_t k = 0; k < scans.NumChunks(); ++k) {
    GS_RETURN_IF_ERROR(scans.Load(k, &chunk));
    for (Scan& scan : chunk) {
      if (poses != nullptr) {
        if (scan.pose < 0 || scan.pose >= static_cast<int64_t>(poses->size())) {
          return Status::InvalidArgument("scan " + std::to_string(summary.scans) + " belongs to pose " +
                                         std::to_string(scan.pose) + ", but the trajectory has " +
                                         std::to_string(poses->size()) + " poses");
        }
        scan.sensor_pose = (*poses)[static_cast<size_t>(scan.pose)];
      }
      WorldScan world;
      world.origin = scan.sensor_pose.t.cast<float>();
      world.points = WorldPoints(scan);
      if (cloud) GS_RETURN_IF_ERROR(cloud->Add(world.points, scan));
      ++summary.scans;
      summary.points += static_cast<int64_t>(world.points.size());
      batch_points += static_cast<int64_t>(world.points.size());
      batch.push_back(std::move(world));
      if (batch_points >= options.batch_points) GS_RETURN_IF_ERROR(flush());
    }
  }
  if (!batch.empty()) GS_RETURN_IF_ERROR(flush());
  summary.fusion_seconds = seconds;
  summary.points_per_second = seconds > 0 ? static_cast<double>(summary.points) / seconds : 0.0;
  summary.tree_bytes = static_cast<int64_t>(fusion.MemoryUsage());
  summary.fusion_peak_bytes = static_cast<int64_t>(fusion.memory_stats().peak_accounted_bytes);
  summary.fusion_peak_code_bytes = static_cast<int64_t>(fusion.memory_stats().peak_code_bytes);
  summary.fusion_peak_resident_tiles = static_cast<int64_t>(fusion.memory_stats().peak_resident_tiles);
  summary.tile_spills = fusion.spills();
  summary.tiles = static_cast<int64_t>(fusion.num_tiles());

  if (!options.bt_path.empty()) {
    if (summary.tree_bytes <= options.memory_budget_bytes) {
      const auto start = std::chrono::steady_clock::now();
      GS_ASSIGN_OR_RETURN(std::unique_ptr<octomap::OcTree> tree, fusion.Merge());
      summary.fusion_seconds +=
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
        if (tree->isNodeOccupied(*it)) {
          ++summary.occupied_leaves;
        } else {
          ++summary.free_leaves;
        }
      }
      GS_RETURN_IF_ERROR(WriteTree(*tree, options.bt_path));
    } else {
      summary.tiled_output = true;
      const std::string dir = TilesDir(options.bt_path);
      std::error_code ec;
      std::filesystem::create_directories(dir, ec);
      if (ec) return Status::IOError(dir + ": " + ec.message());
      nlohmann::json index;
      index["format"] = "graphslam-octomap-tiles";
      index["version"] = 1;
      index["resolution"] = options.fusion.resolution;
      index["tile_cells"] = 1 << options.fusion.tile_bits;
      nlohmann::json tiles = nlohmann::json::array();
      GS_RETURN_IF_ERROR(fusion.ForEachTile([&](uint64_t id, const octomap::OcTree& tree) {
        char name[48];
        std::snprintf(name, sizeof(name), "tile_%012llx.bt", static_cast<unsigned long long>(id));
        GS_RETURN_IF_ERROR(WriteTree(tree, dir + "/" + name));
        Eigen::Vector3d lo, hi;
        fusion.TileBounds(id, &lo, &hi);
        tiles.push_back({{"file", name},
                         {"min", {lo.x(), lo.y(), lo.z()}},
                         {"max", {hi.x(), hi.y(), hi.z()}}});
        return Status::Ok();
      }));
      index["tiles"] = tiles;
      summary.tiles_index = dir + "/index.json";
      GS_RETURN_IF_ERROR(storage::WriteStringAtomically(storage::Env::Default(), summary.tiles_index,
                                                        index.dump(2) + "\n"));
    }
  }
  if (!options.pcd_path.empty()) {
    GS_RETURN_IF_ERROR(cloud->Finish(options.pcd_path));
    summary.pcd_points = cloud->stats().voxels;
    summary.pcd_tile_spills = cloud->stats().spills;
  }
  return summary;
}

}  // namespace graphslam::map
