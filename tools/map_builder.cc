#include "tools/map_builder.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <sstream>

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

// OUT.bt -> OUT<extension> (the fusion's spill file, the cloud's folder).
std::string WithExtension(const std::string& path, const char* extension) {
  std::filesystem::path p(path);
  p.replace_extension(extension);
  return p.string();
}

// The fusion gets what the cloud (`cloud_bytes`, 0 without a .pcd) and the
// rest of the process leave of the budget, at least a sixteenth of it. The
// rest is kProcessReserve: code and libraries, one chunk of scans, one batch
// of world points, the per-thread buffers of ray casting (docs/tuning.md).
int64_t FusionBudgetBytes(int64_t budget_bytes, int64_t cloud_bytes) {
  const int64_t reserve = std::min(kProcessReserve, budget_bytes / 8);
  return std::max(budget_bytes - reserve - cloud_bytes, budget_bytes / 16);
}

// Scans in the world frame, handed to the fusion in batches of at least
// `batch_points` points; without a .bt nothing is fused and no time counted.
class FusionBatches {
 public:
  FusionBatches(TiledFusion* fusion, bool fuse, int64_t batch_points)
      : fusion_(fusion), fuse_(fuse), batch_points_(batch_points) {}

  Status Add(WorldScan world) {
    points_ += static_cast<int64_t>(world.points.size());
    batch_.push_back(std::move(world));
    if (points_ >= batch_points_) return Flush();
    return Status::Ok();
  }

  Status Flush() {
    if (batch_.empty()) return Status::Ok();
    if (fuse_) {
      const auto start = std::chrono::steady_clock::now();
      GS_RETURN_IF_ERROR(fusion_->Insert(batch_));
      seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      storage::StopPointForTests("map_batch " + std::to_string(++batches_));
    }
    batch_.clear();
    points_ = 0;
    return Status::Ok();
  }

  double seconds() const { return seconds_; }

 private:
  TiledFusion* fusion_;
  bool fuse_;
  int64_t batch_points_;
  std::vector<WorldScan> batch_;
  int64_t points_ = 0;
  double seconds_ = 0.0;
  int64_t batches_ = 0;
};

// The fused tiles merged into one OcTree, written to `bt_path`.
Status WriteMergedTree(const std::string& bt_path, TiledFusion* fusion, MapSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  GS_ASSIGN_OR_RETURN(std::unique_ptr<octomap::OcTree> tree, fusion->Merge());
  summary->fusion_seconds +=
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  for (auto it = tree->begin_leafs(), end = tree->end_leafs(); it != end; ++it) {
    if (tree->isNodeOccupied(*it)) {
      ++summary->occupied_leaves;
    } else {
      ++summary->free_leaves;
    }
  }
  return WriteTree(*tree, bt_path);
}

// A map larger than the budget: one .bt per tile in OUT.tiles/, and
// OUT.tiles/index.json with each tile's file and bounds.
Status WriteTiles(const MapOptions& options, TiledFusion* fusion, MapSummary* summary) {
  summary->tiled_output = true;
  const std::string dir = TilesDir(options.bt_path);
  GS_RETURN_IF_ERROR(storage::Env::Default()->CreateDir(dir));
  nlohmann::json index;
  index["format"] = "graphslam-octomap-tiles";
  index["version"] = 1;
  index["resolution"] = options.fusion.resolution;
  index["tile_cells"] = 1 << options.fusion.tile_bits;
  nlohmann::json tiles = nlohmann::json::array();
  GS_RETURN_IF_ERROR(fusion->ForEachTile([&](uint64_t id, const octomap::OcTree& tree) {
    char name[48];
    std::snprintf(name, sizeof(name), "tile_%012llx.bt", static_cast<unsigned long long>(id));
    GS_RETURN_IF_ERROR(WriteTree(tree, dir + "/" + name));
    Eigen::Vector3d lo, hi;
    fusion->TileBounds(id, &lo, &hi);
    tiles.push_back({{"file", name},
                     {"min", {lo.x(), lo.y(), lo.z()}},
                     {"max", {hi.x(), hi.y(), hi.z()}}});
    return Status::Ok();
  }));
  index["tiles"] = tiles;
  summary->tiles_index = dir + "/index.json";
  return storage::WriteStringAtomically(storage::Env::Default(), summary->tiles_index,
                                        index.dump(2) + "\n");
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
    const int64_t fusion_bytes = FusionBudgetBytes(
        options.memory_budget_bytes, options.pcd_path.empty() ? 0 : cloud_options.budget_bytes);
    fusion.EnableSpill(WithExtension(options.bt_path, ".spill"),
                       static_cast<size_t>(fusion_bytes));
  }
  std::optional<TiledVoxelCloud> cloud;  // only with a .pcd: it owns OUT.voxels/
  if (!options.pcd_path.empty()) {
    cloud_options.spill_dir = WithExtension(options.pcd_path, ".voxels");
    cloud.emplace(cloud_options);
  }
  FusionBatches batches(&fusion, fuse, options.batch_points);
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
      GS_RETURN_IF_ERROR(batches.Add(std::move(world)));
    }
  }
  GS_RETURN_IF_ERROR(batches.Flush());
  summary.fusion_seconds = batches.seconds();
  summary.points_per_second =
      batches.seconds() > 0 ? static_cast<double>(summary.points) / batches.seconds() : 0.0;
  summary.tree_bytes = static_cast<int64_t>(fusion.MemoryUsage());
  summary.fusion_peak_bytes = static_cast<int64_t>(fusion.memory_stats().peak_accounted_bytes);
  summary.fusion_peak_code_bytes = static_cast<int64_t>(fusion.memory_stats().peak_code_bytes);
  summary.fusion_peak_resident_tiles = static_cast<int64_t>(fusion.memory_stats().peak_resident_tiles);
  summary.tile_spills = fusion.spills();
  summary.tiles = static_cast<int64_t>(fusion.num_tiles());

  if (fuse) {
    if (summary.tree_bytes <= options.memory_budget_bytes) {
      GS_RETURN_IF_ERROR(WriteMergedTree(options.bt_path, &fusion, &summary));
    } else {
      GS_RETURN_IF_ERROR(WriteTiles(options, &fusion, &summary));
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
