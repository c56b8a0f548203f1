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
// Memory: the tile trees plus the codes of the scans being fused, together
// bounded by EnableSpill (runs of scans, groups of tiles; see there).
// THREAD SAFETY: one TiledFusion per thread; it parallelizes internally (TBB).
// ALLOCATION: the tile trees (the map), plus the codes of a run of scans
// (8 bytes per unique ray cell of a scan); per thread, the scan being cast
// (at most ~8 bytes per ray cell before de-duplication, bounded by sorting
// and de-duplicating whenever its buffer passes 4 M codes; not counted).
#pragma once

#include <octomap/OcTree.h>

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <utility>
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

// [begin, end) of one tile's codes in a sorted code list.
struct TileCodeRange {
  uint64_t tile;
  size_t begin, end;
};

class TiledFusion {
 public:
  explicit TiledFusion(const FusionOptions& options);
  ~TiledFusion();

  // Keeps the fusion's accounted memory within `budget_bytes`: the resident
  // tile trees (heap bytes, see MemoryUsage, at their high-water mark before
  // pruning) plus the codes of the scans being fused (kept below a quarter
  // of the budget by fusing a batch in runs of scans). The tiles a run
  // touches are fused in groups that fit beside the codes, sized with a
  // growth guess of kGrowthBytesPerCode per code; before each group the least
  // recently touched tiles are written to `dir` (OctoMap's writeData: every
  // node with its float log-odds, so reading back is bit-exact) and freed,
  // and after a run the tiles go down to half the budget once past three
  // quarters. A tile bigger than the budget alone is still fused (the budget
  // is then exceeded: see memory_stats). The files are scratch (removed when
  // read back or when the fusion ends).
  void EnableSpill(const std::string& dir, size_t budget_bytes);

  // What the budget was kept on, for tests and reports.
  struct MemoryStats {
    size_t peak_accounted_bytes = 0;  // resident tiles (high water) + codes
    size_t peak_code_bytes = 0;       // codes of one run of scans
    size_t peak_resident_tiles = 0;
    size_t max_tile_bytes = 0;        // one tile's high water
    double max_growth_per_code = 0;   // heap bytes a tile grew per code it received
    int64_t groups = 0;               // tile groups fused
  };
  const MemoryStats& memory_stats() const { return stats_; }

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
  // Per scan of a run: F and O as sorted codes, and their tile ranges.
  struct BatchCodes {
    std::vector<std::vector<uint64_t>> free, occupied;
    std::vector<std::vector<TileCodeRange>> free_ranges, occupied_ranges;
    void Clear();
    void Resize(size_t scans);
    size_t ScanBytes(size_t i) const;  // heap bytes of scan i's codes (capacities)
    size_t Bytes() const;              // of all scans
  };
  // The budget's share for codes is 1 / kCodeShare. A group's tiles are
  // sized before fusing as their bytes plus kGrowthBytesPerCode per code
  // they receive: a guess (a new leaf costs 32 bytes plus 80 per new child
  // array, an expanded pruned node 336 bytes a level; most codes update
  // existing leaves and cost nothing). The budget is checked on the high
  // water measured afterwards (MemoryStats); a guess too low shows there.
  static constexpr size_t kCodeShare = 4;
  static constexpr size_t kGrowthBytesPerCode = 160;
  static constexpr size_t kNewTileBytes = 1024;  // the path root -> tile node

  [[nodiscard]] Status Apply(const BatchCodes& codes);
  size_t ResidentBytes() const;
  void NoteAccounted(size_t bytes);
  [[nodiscard]] Status SpillOutside(const std::vector<uint64_t>& touched, size_t group_begin,
                                    size_t group_end, size_t room);
  [[nodiscard]] Status SpillLru(std::vector<std::pair<int64_t, uint64_t>> lru, size_t resident,
                                size_t target_bytes);
  std::string SpillPath(uint64_t tile_id) const;
  [[nodiscard]] Status Load(uint64_t tile_id, Tile* tile) const;
  [[nodiscard]] Status Spill(uint64_t tile_id, Tile* tile);
  // Spills resident tiles, least recently touched first, down to
  // target_bytes once they exceed trigger_bytes.
  [[nodiscard]] Status SpillLeastRecent(size_t trigger_bytes, size_t target_bytes);

  FusionOptions options_;
  std::unique_ptr<octomap::OcTree> keyer_;  // computeRayKeys (const) only
  std::map<uint64_t, Tile> tiles_;
  int64_t points_ = 0;
  int64_t batches_ = 0;
  int64_t spills_ = 0;
  std::string spill_dir_;  // empty: no spilling
  size_t budget_bytes_ = 0;
  MemoryStats stats_;
};

}  // namespace graphslam::map
