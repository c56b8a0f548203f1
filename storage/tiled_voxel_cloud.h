// The registered cloud's voxel downsampling within a memory budget (issue 5:
// "a .pcd of the registered cloud, voxel-downsampled, ... within the memory
// budget"), written as one PCD v0.7 binary_compressed file.
//
// Rule (as VoxelCloud in storage/pcd_io.h, the in-memory reference): a point
// p goes to voxel v = floor(p / voxel) (21 bits an axis); a voxel's point is
// the centroid of its points, sum(p) / n with the sums in double in arrival
// order, its intensity the mean, its run the run of its first point.
//
// Bounded: voxels are grouped in cubic tiles of 2^tile_bits voxels a side.
// After every scan, if the resident tiles' estimated heap (kBytesPerVoxel a
// voxel) exceeds `budget_bytes`, the least recently touched tiles are written
// to SPILL_DIR/tile_<id>.vox (their accumulators: raw doubles) and freed
// until at most half the budget is resident; a scan that touches a spilled
// tile reads it back first. Every voxel's sums therefore see the same
// additions in the same order as without a budget: the output is bit for bit
// the unbounded one (tested with a budget that spills at every scan).
//
// Output order: tile by tile (ascending tile (x, y, z)), inside a tile
// ascending voxel (x, y, z) -- deterministic; the file does not depend on
// the budget.
//
// Writing (Finish): tiles are finalized one at a time; each field's values
// (x, y, z [, intensity] [, run]) are LZF-compressed by PCL's own lzfCompress
// in segments of 1 MiB into SPILL_DIR/column_<f>.lzf; the file is PCL's
// binary_compressed header (PCL's generateHeaderBinaryCompressed), the
// compressed and uncompressed sizes (u32 each), then the columns in field
// order, written through a temp file + fsync + rename (storage/atomic_file.h).
// An LZF stream is a sequence of self-contained literal runs and back
// references, so independently compressed segments concatenate into one
// valid stream, which pcl::io::loadPCDFile decompresses in one call (tested).
// PCL's writer itself needs the whole cloud in memory (one PCLPointCloud2
// plus its column copy and compressed buffer), which is what this avoids.
// Limit of the format: at most 4 GiB uncompressed (u32 sizes).
//
// THREAD SAFETY: one thread at a time. ALLOCATION: the resident tiles (about
// budget_bytes), one tile being finalized, 1 MiB of column buffers.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/scan.h"
#include "core/status.h"

namespace graphslam::map {

struct TiledVoxelCloudOptions {
  double voxel = 0.1;
  int tile_bits = 9;                       // tiles of 2^bits voxels a side
  int64_t budget_bytes = int64_t{1} << 30;  // resident tiles
  std::string spill_dir;                   // created on the first spill / Finish; removed by Finish
};

struct TiledVoxelCloudStats {
  int64_t voxels = 0;          // points written
  int64_t tiles = 0;
  int64_t spills = 0;          // tile writes to disk
  int64_t reloads = 0;         // tile reads back
  int64_t peak_resident_bytes = 0;  // estimated
};

class TiledVoxelCloud {
 public:
  // Estimated heap of one voxel in a tile: an unordered_map node (next
  // pointer, key, 48-byte accumulator: 64 bytes, an 80-byte malloc chunk)
  // plus its bucket.
  static constexpr int64_t kBytesPerVoxel = 96;

  explicit TiledVoxelCloud(TiledVoxelCloudOptions options);
  ~TiledVoxelCloud();

  // Adds the scan's points (world frame) with its intensities and run id;
  // then spills if over budget. IOError naming the spill file.
  [[nodiscard]] Status Add(const std::vector<Eigen::Vector3f>& world_points, const Scan& scan);

  // Writes the cloud to `path` (atomically) and removes the spill folder.
  // The cloud is empty afterwards.
  [[nodiscard]] Status Finish(const std::string& path);

  const TiledVoxelCloudStats& stats() const { return stats_; }

 private:
  struct Accumulator {
    double x = 0, y = 0, z = 0, intensity = 0;
    int64_t count = 0;
    int32_t run = -1;
  };
  struct Tile {
    std::unordered_map<uint64_t, Accumulator> voxels;
    bool resident = true;  // else in spill_dir/tile_<id>.vox
    uint64_t last_touch = 0;
  };

  Status Touch(uint64_t id, Tile* tile);  // resident, reloaded if spilled
  Status Spill(uint64_t id, Tile* tile);
  Status Reload(uint64_t id, Tile* tile);
  Status EnforceBudget();
  std::string TilePath(uint64_t id) const;

  TiledVoxelCloudOptions options_;
  std::map<uint64_t, Tile> tiles_;  // by tile id (x, y, z), ascending = output order
  int64_t resident_voxels_ = 0;
  uint64_t clock_ = 0;
  bool has_intensity_ = false;
  bool has_run_ = false;
  TiledVoxelCloudStats stats_;
};

}  // namespace graphslam::map
