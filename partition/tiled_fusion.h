// Occupancy fusion of registered scans into an OctoMap, tiled and parallel,
// with exactly the result of OctoMap's own serial
//
//   for each scan s (in order): tree.insertPointCloud(s.points, s.origin, max_range)
//
// (lazy_eval = false, discretize = false, no bounding box).
//
// Why the result is identical. insertPointCloud computes, per scan, the set F
// of cells crossed by the rays origin->endpoint (OcTreeBaseImpl::computeRayKeys;
// rays longer than max_range are cut there and have no endpoint) and the set O
// of endpoint cells, removes O from F ("occupied wins"), then applies one
// log-odds update per cell: l <- clamp(l + l_miss) for F, l <- clamp(l + l_hit)
// for O (OccupancyOcTreeBase::updateNode; the early abort at a clamping bound
// and pruning/expansion of equal children do not change any leaf's value). So
// a leaf's final log-odds depends only on the sequence of updates that leaf
// receives, in scan order, and never on other leaves.
//
// Here, per batch of scans:
//   1. (parallel over scans) F and O of each scan with the same computeRayKeys
//      and coordToKeyChecked, as sorted unique 48-bit codes
//         code = tile_id << 3k | (x & m) << 2k | (y & m) << k | (z & m),
//         tile_id = (x >> k) << 2t | (y >> k) << t | (z >> k),  t = 16 - k,
//      m = 2^k - 1, so a tile (an octree node at depth t: 2^k cells a side)
//      is one contiguous range of codes; F <- F \ O by set difference.
//   2. (parallel over tiles) each tile's own OcTree applies, scan by scan in
//      order, updateNode(key, false) for its part of F and updateNode(key,
//      true) for its part of O (lazily: inner nodes and pruning once per
//      batch, which leaves every leaf's value unchanged). Sorted codes also make these updates walk the
//      tree in spatial order (cache-friendly), unlike the hash order of KeySet.
// Merge: every tile leaf (key, depth, log-odds) is written into one tree at the
// same depth, then inner nodes get the max of their children (as updateNode
// keeps them) and equal children are pruned. Tiles are disjoint octree nodes
// at depth t, so no leaf of a tile is coarser than the tile.
//
// Memory: the tile trees (bounded by EnableSpill), plus per batch the codes.
// THREAD SAFETY: one TiledFusion per thread; it parallelizes internally (TBB).
// ALLOCATION: the tile trees (the map), plus per batch the codes of its scans
// (at most ~8 bytes per ray cell before de-duplication, bounded by sorting
// and de-duplicating whenever a scan's buffer passes 4 M codes).
#pragma once

#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/status.h"

namespace graphslam::map {

struct FusionOptions {
  double resolution = 0.1;  // leaf edge [m]
  double max_range = -1.0;  // [m]; rays are cut here (no endpoint); < 0: unlimited
  double prob_hit = 0.7;    // OctoMap defaults
  double prob_miss = 0.4;
  double clamping_min = 0.1192;
  double clamping_max = 0.971;
  int tile_bits = 9;  // a tile is 2^tile_bits leaves a side (0.1 m -> 51.2 m)

  [[nodiscard]] Status Validate() const;
};

// One scan in the world frame: sensor origin and endpoints.
struct WorldScan {
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  std::vector<Eigen::Vector3f> points;
};

// A fresh OcTree with the options' resolution, probabilities and clamping.
std::unique_ptr<octomap::OcTree> MakeOcTree(const FusionOptions& options);

// The reference: OctoMap's serial insertPointCloud of every scan in order.
std::unique_ptr<octomap::OcTree> FuseSerial(const FusionOptions& options,
                                            const std::vector<WorldScan>& scans);

class TiledFusion {
 public:
  explicit TiledFusion(const FusionOptions& options);
  ~TiledFusion();

  // Keeps the tiles in memory within `budget_bytes` (heap bytes, see
  // MemoryUsage): before a batch reads spilled tiles back and after it, the
  // least recently touched tiles are written to `dir` (OctoMap's writeData: every
  // node with its float log-odds, so reading back is bit-exact) and freed;
  // a batch that touches a spilled tile reads it back first. The files are
  // scratch (removed when read back or when the fusion ends).
  void EnableSpill(const std::string& dir, size_t budget_bytes);

  // Fuses `batch` (after every earlier batch), in order. IOError on spill I/O.
  [[nodiscard]] Status Insert(const std::vector<WorldScan>& batch);

  int64_t points_inserted() const { return points_; }
  size_t num_tiles() const { return tiles_.size(); }
  int64_t spills() const { return spills_; }
  // Heap bytes of all tile trees, spilled ones included (nodes and child
  // arrays as glibc allocates them, as of the batch that last touched each;
  // about twice OcTree::memoryUsage, which counts the payload only).
  size_t MemoryUsage() const;

  // Moves every tile into one tree (the tiles are freed one by one as they are
  // merged, so the peak is about one map) and returns it. Ends the fusion.
  [[nodiscard]] StatusOr<std::unique_ptr<octomap::OcTree>> Merge();

  // Calls fn(tile_id, tree) for every tile in tile order, reading spilled
  // tiles back one at a time. Each tree is a full-size OcTree holding only
  // the cells of its tile.
  [[nodiscard]] Status ForEachTile(
      const std::function<Status(uint64_t, const octomap::OcTree&)>& fn);
  // The tile's bounding box in the world [m].
  void TileBounds(uint64_t tile_id, Eigen::Vector3d* min, Eigen::Vector3d* max) const;

 private:
  struct Tile {
    std::unique_ptr<octomap::OcTree> tree;  // null while spilled
    size_t bytes = 0;
    int64_t last_batch = 0;
  };
  std::string SpillPath(uint64_t tile_id) const;
  [[nodiscard]] Status Load(uint64_t tile_id, Tile* tile) const;
  [[nodiscard]] Status Spill(uint64_t tile_id, Tile* tile);
  // Spills resident tiles, least recently touched first, down to
  // target_bytes once they exceed twice that; with keep_current_batch the
  // tiles of the batch being fused are kept.
  [[nodiscard]] Status SpillLeastRecent(size_t target_bytes, bool keep_current_batch);

  FusionOptions options_;
  std::unique_ptr<octomap::OcTree> keyer_;  // computeRayKeys (const) only
  std::map<uint64_t, Tile> tiles_;
  int64_t points_ = 0;
  int64_t batches_ = 0;
  int64_t spills_ = 0;
  std::string spill_dir_;  // empty: no spilling
  size_t budget_bytes_ = 0;
};

}  // namespace graphslam::map
