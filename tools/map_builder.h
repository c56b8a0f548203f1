// BuildMap: every scan, moved by its (optimized) pose, fused into one OctoMap
// (ray casting from the sensor origin; partition/fusion/tiled_fusion.h) and into a
// voxel-downsampled registered cloud (storage/pcd_io.h).
//
//   sensor pose of a scan = poses[scan.pose]   when `poses` is given (the
//                                              solved trajectory, one row per
//                                              pose; the sensor frame is the
//                                              body frame),
//                         = scan.sensor_pose   otherwise (as logged).
//
// Scans are read chunk by chunk (one chunk in memory) and fused in batches of
// about `batch_points` points. Output:
//   - bt_path: one .bt (OctoMap's binary, maximum-likelihood) of the merged
//     tree, when the tiles' heap bytes are within memory_budget_bytes;
//   - otherwise <bt_path minus .bt>.tiles/tile_<id>.bt, one per spatial tile
//     (each a full OcTree holding only its tile's cells), plus index.json in
//     that folder listing every tile file with its world bounding box;
//   - pcd_path: the registered cloud (binary_compressed), downsampled in
//     tiles within pcd_memory_bytes (storage/tiled_voxel_cloud.h).
// Every file is written atomically.
//
// THREAD SAFETY: one call at a time per output path; parallel inside (TBB).
// ALLOCATION: within memory_budget_bytes: the map's resident tiles and the
// codes of the scans being fused (the budget minus the cloud's share with a
// .pcd, minus a reserve of min(64 MiB, budget / 8) for the rest of the
// process), the cloud's resident voxel tiles (pcd_memory_bytes), one chunk
// of scans and one batch of world points.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/se3.h"
#include "core/status.h"
#include "storage/scan_store.h"
#include "partition/fusion/tiled_fusion.h"

namespace graphslam::map {

struct MapOptions {
  FusionOptions fusion;
  std::string bt_path;   // "" : no OctoMap output
  std::string pcd_path;  // "" : no cloud output
  double pcd_voxel = 0.0;  // <= 0: fusion.resolution
  int64_t memory_budget_bytes = int64_t{4} << 30;
  // Resident voxels of the registered cloud (storage/tiled_voxel_cloud.h;
  // spilled to <pcd_path minus .pcd>.voxels/ beyond); 0: memory_budget_bytes / 4.
  int64_t pcd_memory_bytes = 0;
  int64_t batch_points = 2'000'000;

  [[nodiscard]] Status Validate() const;
};

struct MapSummary {
  int64_t scans = 0;
  int64_t points = 0;          // points fused (all rays)
  int64_t occupied_leaves = 0;  // of the merged tree (0 when tiled)
  int64_t free_leaves = 0;
  int64_t tree_bytes = 0;       // heap bytes of the tiles before merging (TiledFusion::MemoryUsage)
  int64_t tiles = 0;
  bool tiled_output = false;
  std::string tiles_index;      // index.json when tiled_output
  int64_t pcd_points = 0;
  int64_t pcd_tile_spills = 0;  // voxel tiles written to disk (0: the cloud fit its budget)
  // The fusion's accounted memory (partition/fusion/tiled_fusion.h, MemoryStats):
  // its peak (resident tiles + codes), the codes' peak, the most tiles
  // resident at once, and tiles written to disk.
  int64_t fusion_peak_bytes = 0;
  int64_t fusion_peak_code_bytes = 0;
  int64_t fusion_peak_resident_tiles = 0;
  int64_t tile_spills = 0;
  double fusion_seconds = 0.0;  // wall time of ray casting + updates
  double points_per_second = 0.0;
};

[[nodiscard]] StatusOr<MapSummary> BuildMap(const MapOptions& options, const ScanSource& scans,
                                            const std::vector<core::Pose3>* poses);

}  // namespace graphslam::map
