#include "partition/fusion/tiled_fusion.h"

#include <tbb/enumerable_thread_specific.h>
#include <malloc.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <system_error>
#include <iterator>
#include <string>
#include <utility>

#include "storage/env.h"

namespace graphslam::map {
namespace {

constexpr int kKeyBits = 16;  // octomap::OcTree: tree depth 16, 16-bit keys

// Morton (octree) order: bits 3l, 3l+1, 3l+2 of a code are bit l of x, y, z,
// i.e. the child index at level l (OcTreeKey computeChildIdx). A tile (an
// octree node at depth 16 - k) is then the code's top 3(16 - k) bits.
uint64_t Spread(uint64_t v) {
  v &= 0xFFFF;
  v = (v | v << 32) & 0x1F00000000FFFFull;
  v = (v | v << 16) & 0x1F0000FF0000FFull;
  v = (v | v << 8) & 0x100F00F00F00F00Full;
  v = (v | v << 4) & 0x10C30C30C30C30C3ull;
  v = (v | v << 2) & 0x1249249249249249ull;
  return v;
}
uint64_t Compact(uint64_t v) {
  v &= 0x1249249249249249ull;
  v = (v ^ (v >> 2)) & 0x10C30C30C30C30C3ull;
  v = (v ^ (v >> 4)) & 0x100F00F00F00F00Full;
  v = (v ^ (v >> 8)) & 0x1F0000FF0000FFull;
  v = (v ^ (v >> 16)) & 0x1F00000000FFFFull;
  v = (v ^ (v >> 32)) & 0x1FFFFFull;
  return v;
}

struct Codec {
  int k;  // levels inside a tile

  explicit Codec(int tile_bits) : k(tile_bits) {}

  static uint64_t Encode(const octomap::OcTreeKey& key) {
    return Spread(key[0]) | (Spread(key[1]) << 1) | (Spread(key[2]) << 2);
  }
  uint64_t Tile(uint64_t code) const { return code >> (3 * k); }
  static octomap::OcTreeKey Decode(uint64_t code) {
    return octomap::OcTreeKey(static_cast<octomap::key_type>(Compact(code)),
                              static_cast<octomap::key_type>(Compact(code >> 1)),
                              static_cast<octomap::key_type>(Compact(code >> 2)));
  }
};

void SortUnique(std::vector<uint64_t>* codes) {
  std::sort(codes->begin(), codes->end());
  codes->erase(std::unique(codes->begin(), codes->end()), codes->end());
}

// A direct-mapped filter of recently pushed codes: most ray cells repeat
// those of the previous rays (all rays share the cells near the origin), so
// skipping a code seen recently shrinks the buffer to sort several-fold. It
// only drops exact duplicates, so the sorted unique set is unchanged.
// Sized to the scan (about 4 slots a point, 2^10..2^16) so that small scans
// (a push-broom line of a few hundred points) do not pay for a big table.
class RecentCodes {
 public:
  explicit RecentCodes(size_t points) {
    while (bits_ < 16 && (size_t{1} << bits_) < 4 * points) ++bits_;
    slots_.assign(size_t{1} << bits_, ~uint64_t{0});
  }
  // True if `code` was seen recently; remembers it otherwise.
  bool SeenOrRemember(uint64_t code) {
    uint64_t& slot = slots_[(code * 0x9E3779B97F4A7C15ull) >> (64 - bits_)];
    if (slot == code) return true;
    slot = code;
    return false;
  }

 private:
  int bits_ = 10;
  std::vector<uint64_t> slots_;
};

// F and O of one scan, as computeUpdate makes them (see the header).
void ComputeScanCodes(const octomap::OcTree& keyer, const Codec& codec, const WorldScan& scan,
                      double max_range, octomap::KeyRay* ray, std::vector<uint64_t>* free_codes,
                      std::vector<uint64_t>* occupied_codes) {
  constexpr size_t kDedupAt = size_t{4} << 20;
  size_t dedup_at = kDedupAt;
  free_codes->clear();
  occupied_codes->clear();
  RecentCodes recent(scan.points.size());
  auto push_ray = [&](const octomap::KeyRay& keys) {
    for (const octomap::OcTreeKey& key : keys) {
      const uint64_t code = codec.Encode(key);
      if (!recent.SeenOrRemember(code)) free_codes->push_back(code);
    }
  };
  const octomap::point3d origin(scan.origin.x(), scan.origin.y(), scan.origin.z());
  for (const Eigen::Vector3f& q : scan.points) {
    const octomap::point3d p(q.x(), q.y(), q.z());
    if (max_range < 0.0 || (p - origin).norm() <= max_range) {
      if (keyer.computeRayKeys(origin, p, *ray)) push_ray(*ray);
      octomap::OcTreeKey key;
      if (keyer.coordToKeyChecked(p, key)) occupied_codes->push_back(codec.Encode(key));
    } else {
      const octomap::point3d direction = (p - origin).normalized();
      const octomap::point3d new_end = origin + direction * static_cast<float>(max_range);
      if (keyer.computeRayKeys(origin, new_end, *ray)) push_ray(*ray);
    }
    if (free_codes->size() > dedup_at) {
      SortUnique(free_codes);
      dedup_at = std::max(kDedupAt, 2 * free_codes->size());
    }
  }
  SortUnique(free_codes);
  SortUnique(occupied_codes);
  std::vector<uint64_t> difference;
  difference.reserve(free_codes->size());
  std::set_difference(free_codes->begin(), free_codes->end(), occupied_codes->begin(),
                      occupied_codes->end(), std::back_inserter(difference));
  free_codes->swap(difference);
}

// [begin, end) of each tile in a sorted code list, ordered by tile id.
using TileRange = TileCodeRange;
std::vector<TileRange> SplitByTile(const Codec& codec, const std::vector<uint64_t>& codes) {
  std::vector<TileRange> ranges;
  size_t i = 0;
  while (i < codes.size()) {
    const uint64_t tile = codec.Tile(codes[i]);
    size_t j = i + 1;
    while (j < codes.size() && codec.Tile(codes[j]) == tile) ++j;
    ranges.push_back({tile, i, j});
    i = j;
  }
  return ranges;
}

const TileRange* FindTile(const std::vector<TileRange>& ranges, uint64_t tile) {
  auto it = std::lower_bound(ranges.begin(), ranges.end(), tile,
                             [](const TileRange& r, uint64_t t) { return r.tile < t; });
  return it != ranges.end() && it->tile == tile ? &*it : nullptr;
}

// An OcTree that accepts a leaf at any depth (the merge target).
class MergeTree : public octomap::OcTree {
 public:
  using octomap::OcTree::OcTree;

  void SetLeaf(const octomap::OcTreeKey& key, unsigned depth, float log_odds) {
    if (root == nullptr) {
      root = new octomap::OcTreeNode();
      ++tree_size;
    }
    octomap::OcTreeNode* node = root;
    for (unsigned d = 0; d < depth; ++d) {
      const unsigned child = octomap::computeChildIdx(key, static_cast<int>(tree_depth - 1 - d));
      node = nodeChildExists(node, child) ? getNodeChild(node, child)
                                          : createNodeChild(node, child);
    }
    node->setLogOdds(log_odds);
  }
};

// A tile's tree, updated from sorted codes with one descent shared between
// consecutive codes. Equivalent, leaf by leaf, to OcTree::updateNode(key,
// occupied, lazy_eval = true) per code: the same child creation and pruned-node
// expansion as updateNodeRecurs, the same clamped addition at the leaf. (It
// skips updateNode's early abort at a clamping bound, which changes no value:
// the clamped sum equals the bound again.) Inner nodes are left stale, as in a
// lazy update; the caller runs updateInnerOccupancy() and prune() afterwards.
class TileTree : public octomap::OcTree {
 public:
  using octomap::OcTree::OcTree;

  // Heap bytes allocated by ApplySorted since the last reset, as glibc
  // allocates them (see HeapBytes): 32 per node, 80 per child array. With the
  // tree's bytes before, this is its size before prune() frees anything,
  // i.e. the tile's high-water mark within a batch.
  size_t grown_bytes = 0;

  void ApplySorted(const uint64_t* codes, size_t n, bool occupied) {
    if (n == 0) return;
    const float update = occupied ? prob_hit_log : prob_miss_log;
    constexpr int kDepth = 16;
    octomap::OcTreeNode* path[kDepth + 1];
    bool just_created = false;
    if (root == nullptr) {
      root = new octomap::OcTreeNode();
      ++tree_size;
      grown_bytes += 32;
      just_created = true;
    }
    path[0] = root;
    uint64_t previous = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint64_t code = codes[i];
      int depth = 0;
      if (i > 0) {
        // The first level (from the root) where this code's path leaves the
        // previous one: everything above is shared and already exists.
        const int highest = 63 - __builtin_clzll(code ^ previous);
        depth = kDepth - 1 - highest / 3;
        just_created = false;
      }
      octomap::OcTreeNode* node = path[depth];
      for (; depth < kDepth; ++depth) {
        const unsigned child = static_cast<unsigned>((code >> (3 * (kDepth - 1 - depth))) & 7);
        bool created = false;
        if (!nodeChildExists(node, child)) {
          if (!nodeHasChildren(node) && !just_created) {
            expandNode(node);
            grown_bytes += 80 + 8 * 32;
          } else {
            if (!nodeHasChildren(node)) grown_bytes += 80;
            createNodeChild(node, child);
            grown_bytes += 32;
            created = true;
          }
        }
        node = getNodeChild(node, child);
        just_created = created;
        path[depth + 1] = node;
      }
      float value = node->getLogOdds() + update;
      if (value < clamping_thres_min) value = clamping_thres_min;
      if (value > clamping_thres_max) value = clamping_thres_max;
      node->setLogOdds(value);
      previous = code;
    }
  }
};

}  // namespace

Status FusionOptions::Validate() const {
  if (!(resolution > 0.0) || !std::isfinite(resolution)) {
    return Status::InvalidArgument("resolution must be > 0, got " + std::to_string(resolution));
  }
  if (!std::isfinite(max_range)) return Status::InvalidArgument("max_range must be finite");
  if (!(prob_hit > 0.5 && prob_hit < 1.0) || !(prob_miss > 0.0 && prob_miss < 0.5)) {
    return Status::InvalidArgument("need 0.5 < prob_hit < 1 and 0 < prob_miss < 0.5");
  }
  if (!(clamping_min > 0.0 && clamping_min < 0.5 && clamping_max > 0.5 && clamping_max < 1.0)) {
    return Status::InvalidArgument("need 0 < clamping_min < 0.5 < clamping_max < 1");
  }
  if (tile_bits < 1 || tile_bits > 15) {
    return Status::InvalidArgument("tile_bits must be in [1, 15], got " +
                                   std::to_string(tile_bits));
  }
  return Status::Ok();
}

std::unique_ptr<octomap::OcTree> MakeOcTree(const FusionOptions& options) {
  auto tree = std::make_unique<octomap::OcTree>(options.resolution);
  tree->setProbHit(options.prob_hit);
  tree->setProbMiss(options.prob_miss);
  tree->setClampingThresMin(options.clamping_min);
  tree->setClampingThresMax(options.clamping_max);
  return tree;
}

std::unique_ptr<octomap::OcTree> FuseSerial(const FusionOptions& options,
                                            const std::vector<WorldScan>& scans) {
  std::unique_ptr<octomap::OcTree> tree = MakeOcTree(options);
  octomap::Pointcloud cloud;
  for (const WorldScan& scan : scans) {
    cloud.clear();
    cloud.reserve(scan.points.size());
    for (const Eigen::Vector3f& p : scan.points) cloud.push_back(p.x(), p.y(), p.z());
    tree->insertPointCloud(cloud, octomap::point3d(scan.origin.x(), scan.origin.y(), scan.origin.z()),
                           options.max_range);
  }
  return tree;
}

namespace {

// Heap bytes of a tree as glibc allocates them: every node is a 16-byte
// OcTreeNode in a 32-byte chunk, and every inner node also owns a 64-byte
// array of child pointers in an 80-byte chunk. OcTree::memoryUsage counts the
// payload only (about half of this), so a budget kept on it lets the process
// grow to twice the budget (docs/tuning.md).
size_t HeapBytes(const octomap::OcTree& tree) {
  const size_t nodes = tree.size();
  const size_t leaves = tree.getNumLeafNodes();
  return 32 * nodes + 80 * (nodes - leaves);
}

std::unique_ptr<octomap::OcTree> MakeTileTree(const FusionOptions& options) {
  auto tree = std::make_unique<TileTree>(options.resolution);
  tree->setProbHit(options.prob_hit);
  tree->setProbMiss(options.prob_miss);
  tree->setClampingThresMin(options.clamping_min);
  tree->setClampingThresMax(options.clamping_max);
  return tree;
}

}  // namespace

TiledFusion::TiledFusion(const FusionOptions& options)
    : options_(options), keyer_(MakeOcTree(options)) {}

TiledFusion::~TiledFusion() {
  if (spill_dir_.empty()) return;
  for (const auto& [id, tile] : tiles_) {
    if (!tile.tree) {
      // scratch; best effort
      static_cast<void>(storage::Env::Default()->RemoveFile(SpillPath(id)));
    }
  }
  // only if empty (it is ours then)
  static_cast<void>(storage::Env::Default()->RemoveDir(spill_dir_));
}

void TiledFusion::EnableSpill(const std::string& dir, size_t budget_bytes) {
  spill_dir_ = dir;
  budget_bytes_ = budget_bytes;
}

std::string TiledFusion::SpillPath(uint64_t tile_id) const {
  return spill_dir_ + "/tile_" + std::to_string(tile_id) + ".octree-data";
}

Status TiledFusion::Load(uint64_t tile_id, Tile* tile) const {
  const std::string path = SpillPath(tile_id);
  StatusOr<std::string> bytes = storage::ReadFileToString(storage::Env::Default(), path);
  if (!bytes.ok()) return Status::IOError(path + ": cannot open spilled tile");
  std::istringstream in(std::move(bytes).value());
  std::unique_ptr<octomap::OcTree> tree = MakeTileTree(options_);
  tree->readData(in);
  if (!in) return Status::IOError(path + ": cannot read spilled tile");
  tile->tree = std::move(tree);
  return Status::Ok();
}

Status TiledFusion::Spill(uint64_t tile_id, Tile* tile) {
  const std::string path = SpillPath(tile_id);
  std::ostringstream out(std::ios::binary);
  tile->tree->writeData(out);
  if (!out) return Status::IOError(path + ": cannot write spilled tile");
  // One tile's bytes are held twice for a moment (the tree and its image).
  GS_ASSIGN_OR_RETURN(std::unique_ptr<storage::WritableFile> file,
                      storage::Env::Default()->NewWritableFile(path));
  GS_RETURN_IF_ERROR(file->Append(out.view()));
  GS_RETURN_IF_ERROR(file->Close());
  tile->tree.reset();
  ++spills_;
  return Status::Ok();
}

Status TiledFusion::Insert(const std::vector<WorldScan>& batch) {
  const Codec codec(options_.tile_bits);
  const size_t n = batch.size();
  for (const WorldScan& scan : batch) points_ += static_cast<int64_t>(scan.points.size());
  // Unbounded: the whole batch at once. Within a budget: the codes of a run
  // of scans are kept below a quarter of it (kCodeShare), so a batch is cut
  // into runs, each fused (all its tiles, scan by scan in order) before the
  // next one's codes are made; every leaf sees the same updates in the same
  // order, so the map is the same.
  const bool bounded = !spill_dir_.empty();
  const size_t code_share = budget_bytes_ / kCodeShare;
  const size_t max_step = bounded ? std::max<size_t>(2, 2 * static_cast<size_t>(
                                                             tbb::this_task_arena::max_concurrency()))
                                  : std::max<size_t>(n, 1);
  tbb::enumerable_thread_specific<octomap::KeyRay> rays;
  BatchCodes codes;
  size_t begin = 0;
  while (begin < n) {
    codes.Clear();
    size_t end = begin;
    size_t code_bytes = 0, largest_scan = 0;
    while (end < n) {
      // As many scans as fit the share at the largest scan's codes so far
      // (one scan first, to learn it).
      size_t step = 1;
      if (!bounded) {
        step = max_step;
      } else if (largest_scan > 0) {
        step = std::clamp<size_t>((code_share - code_bytes) / largest_scan, 1, max_step);
      }
      const size_t step_end = std::min(n, end + step);
      const size_t first = codes.free.size();
      codes.Resize(first + (step_end - end));
      tbb::parallel_for(end, step_end, [&](size_t i) {
        const size_t c = first + (i - end);
        ComputeScanCodes(*keyer_, codec, batch[i], options_.max_range, &rays.local(),
                         &codes.free[c], &codes.occupied[c]);
        codes.free_ranges[c] = SplitByTile(codec, codes.free[c]);
        codes.occupied_ranges[c] = SplitByTile(codec, codes.occupied[c]);
      });
      end = step_end;
      for (size_t c = first; c < codes.free.size(); ++c) largest_scan = std::max(largest_scan, codes.ScanBytes(c));
      code_bytes = codes.Bytes();
      NoteAccounted(ResidentBytes() + code_bytes);
      stats_.peak_code_bytes = std::max(stats_.peak_code_bytes, code_bytes);
      // Stop before the next step could pass the share.
      if (bounded && code_bytes + largest_scan > code_share) break;
    }
    GS_RETURN_IF_ERROR(Apply(codes));
    begin = end;
  }
  return Status::Ok();
}

void TiledFusion::BatchCodes::Clear() {
  free.clear();
  occupied.clear();
  free_ranges.clear();
  occupied_ranges.clear();
}

void TiledFusion::BatchCodes::Resize(size_t scans) {
  free.resize(scans);
  occupied.resize(scans);
  free_ranges.resize(scans);
  occupied_ranges.resize(scans);
}

size_t TiledFusion::BatchCodes::ScanBytes(size_t i) const {
  return 8 * (free[i].capacity() + occupied[i].capacity()) +
         sizeof(TileRange) * (free_ranges[i].capacity() + occupied_ranges[i].capacity());
}

size_t TiledFusion::BatchCodes::Bytes() const {
  size_t bytes = 0;
  for (size_t i = 0; i < free.size(); ++i) bytes += ScanBytes(i);
  return bytes;
}

size_t TiledFusion::ResidentBytes() const {
  size_t bytes = 0;
  for (const auto& [id, tile] : tiles_) {
    if (tile.tree) bytes += tile.bytes;
  }
  return bytes;
}

void TiledFusion::NoteAccounted(size_t bytes) {
  stats_.peak_accounted_bytes = std::max(stats_.peak_accounted_bytes, bytes);
}

Status TiledFusion::Apply(const BatchCodes& codes) {
  const size_t n = codes.free.size();
  ++batches_;
  // Touched tiles and the codes each receives (its growth estimate).
  std::map<uint64_t, size_t> touched_codes;
  for (size_t i = 0; i < n; ++i) {
    for (const TileRange& r : codes.free_ranges[i]) touched_codes[r.tile] += r.end - r.begin;
    for (const TileRange& r : codes.occupied_ranges[i]) touched_codes[r.tile] += r.end - r.begin;
  }
  std::vector<uint64_t> touched;
  std::vector<size_t> estimate;  // bytes of each touched tile after the updates (guess)
  std::vector<size_t> before_bytes;
  touched.reserve(touched_codes.size());
  for (const auto& [id, count] : touched_codes) {
    touched.push_back(id);
    auto it = tiles_.find(id);
    const size_t before = it == tiles_.end() ? 0 : it->second.bytes;
    before_bytes.push_back(before);
    estimate.push_back(before + kGrowthBytesPerCode * count + kNewTileBytes);
    if (it != tiles_.end()) it->second.last_batch = batches_;
  }
  const size_t code_bytes = codes.Bytes();
  const bool bounded = !spill_dir_.empty();
  const size_t available = budget_bytes_ > code_bytes ? budget_bytes_ - code_bytes : 0;
  // The touched tiles are fused in groups that fit the budget beside the
  // codes (a group of one when a tile alone does not); each tile's updates
  // are independent of the others', so any grouping gives the same map.
  size_t group_begin = 0;
  while (group_begin < touched.size()) {
    size_t group_end = group_begin, group_bytes = 0;
    while (group_end < touched.size() &&
           (!bounded || group_end == group_begin || group_bytes + estimate[group_end] <= available)) {
      group_bytes += estimate[group_end];
      ++group_end;
    }
    ++stats_.groups;
    if (bounded) {
      // Room for the group: spill resident tiles outside it, least recent first.
      const size_t room = available > group_bytes ? available - group_bytes : 0;
      GS_RETURN_IF_ERROR(SpillOutside(touched, group_begin, group_end, room));
    }
    std::vector<Tile*> group_tiles;
    for (size_t j = group_begin; j < group_end; ++j) {
      auto [it, inserted] = tiles_.try_emplace(touched[j]);
      Tile& tile = it->second;
      if (inserted) {
        tile.tree = MakeTileTree(options_);
      } else if (!tile.tree) {
        GS_RETURN_IF_ERROR(Load(touched[j], &tile));
        static_cast<void>(storage::Env::Default()->RemoveFile(SpillPath(touched[j])));
      }
      tile.last_batch = batches_;
      group_tiles.push_back(&tile);
    }
    size_t others = 0;  // resident bytes outside the group
    {
      const size_t resident = ResidentBytes();
      size_t group_before = 0;
      for (const Tile* tile : group_tiles) group_before += tile->bytes;
      others = resident - group_before;
    }
    std::vector<size_t> high_water(group_tiles.size());
    tbb::parallel_for(size_t{0}, group_tiles.size(), [&](size_t g) {
      const uint64_t tile = touched[group_begin + g];
      TileTree* tree = static_cast<TileTree*>(group_tiles[g]->tree.get());
      tree->grown_bytes = 0;
      for (size_t i = 0; i < n; ++i) {
        if (const TileRange* r = FindTile(codes.free_ranges[i], tile)) {
          tree->ApplySorted(codes.free[i].data() + r->begin, r->end - r->begin, false);
        }
        if (const TileRange* r = FindTile(codes.occupied_ranges[i], tile)) {
          tree->ApplySorted(codes.occupied[i].data() + r->begin, r->end - r->begin, true);
        }
      }
      high_water[g] = group_tiles[g]->bytes + tree->grown_bytes;
      // Lazy updates skip the inner nodes and pruning on every update; both
      // are done once per batch here (leaf values are the same either way).
      tree->updateInnerOccupancy();
      tree->prune();
      group_tiles[g]->bytes = HeapBytes(*tree);
    });
    size_t group_high = 0;
    for (size_t g = 0; g < group_tiles.size(); ++g) {
      group_high += high_water[g];
      const size_t count = touched_codes[touched[group_begin + g]];
      const size_t grown = high_water[g] - before_bytes[group_begin + g];
      if (count > 0) {
        stats_.max_growth_per_code =
            std::max(stats_.max_growth_per_code, static_cast<double>(grown) / static_cast<double>(count));
      }
      stats_.max_tile_bytes = std::max(stats_.max_tile_bytes, high_water[g]);
    }
    NoteAccounted(others + group_high + code_bytes);
    size_t resident_tiles = 0;
    for (const auto& [id, tile] : tiles_) resident_tiles += tile.tree ? 1 : 0;
    stats_.peak_resident_tiles = std::max(stats_.peak_resident_tiles, resident_tiles);
    group_begin = group_end;
  }
  // Down to half the budget once past what leaves room for the next codes,
  // so the next batches have room before spilling again.
  return SpillLeastRecent(budget_bytes_ - budget_bytes_ / kCodeShare, budget_bytes_ / 2);
}

Status TiledFusion::SpillOutside(const std::vector<uint64_t>& touched, size_t group_begin,
                                 size_t group_end, size_t room) {
  size_t resident = 0;
  std::vector<std::pair<int64_t, uint64_t>> lru;  // (last batch, tile id)
  for (const auto& [id, tile] : tiles_) {
    if (!tile.tree) continue;
    if (std::binary_search(touched.begin() + static_cast<std::ptrdiff_t>(group_begin),
                           touched.begin() + static_cast<std::ptrdiff_t>(group_end), id)) {
      continue;
    }
    resident += tile.bytes;
    lru.emplace_back(tile.last_batch, id);
  }
  if (resident <= room) return Status::Ok();
  return SpillLru(std::move(lru), resident, room);
}

Status TiledFusion::SpillLeastRecent(size_t trigger_bytes, size_t target_bytes) {
  if (spill_dir_.empty()) return Status::Ok();
  size_t resident = 0;
  std::vector<std::pair<int64_t, uint64_t>> lru;  // (last batch, tile id)
  for (const auto& [id, tile] : tiles_) {
    if (!tile.tree) continue;
    resident += tile.bytes;
    lru.emplace_back(tile.last_batch, id);
  }
  if (resident <= trigger_bytes) return Status::Ok();
  return SpillLru(std::move(lru), resident, target_bytes);
}

Status TiledFusion::SpillLru(std::vector<std::pair<int64_t, uint64_t>> lru, size_t resident,
                             size_t target_bytes) {
  GS_RETURN_IF_ERROR(storage::Env::Default()->CreateDir(spill_dir_));
  std::sort(lru.begin(), lru.end());
  for (const auto& [batch_index, id] : lru) {
    if (resident <= target_bytes) break;
    Tile& tile = tiles_.at(id);
    resident -= tile.bytes;
    GS_RETURN_IF_ERROR(Spill(id, &tile));
  }
  // A tile tree is millions of small nodes; glibc keeps freed ones in its
  // arenas, so without a trim the spilled tiles would still count in RSS.
  malloc_trim(0);
  return Status::Ok();
}

size_t TiledFusion::MemoryUsage() const {
  size_t bytes = 0;
  for (const auto& [id, tile] : tiles_) bytes += tile.bytes;
  return bytes;
}

StatusOr<std::unique_ptr<octomap::OcTree>> TiledFusion::Merge() {
  auto out = std::make_unique<MergeTree>(options_.resolution);
  out->setProbHit(options_.prob_hit);
  out->setProbMiss(options_.prob_miss);
  out->setClampingThresMin(options_.clamping_min);
  out->setClampingThresMax(options_.clamping_max);
  for (auto& [id, tile] : tiles_) {
    if (!tile.tree) {
      GS_RETURN_IF_ERROR(Load(id, &tile));
      static_cast<void>(storage::Env::Default()->RemoveFile(SpillPath(id)));
    }
    for (auto it = tile.tree->begin_leafs(), end = tile.tree->end_leafs(); it != end; ++it) {
      out->SetLeaf(it.getKey(), it.getDepth(), it->getLogOdds());
    }
    tile.tree.reset();
  }
  tiles_.clear();
  out->updateInnerOccupancy();
  out->prune();
  return std::unique_ptr<octomap::OcTree>(std::move(out));
}

Status TiledFusion::ForEachTile(const std::function<Status(uint64_t, const octomap::OcTree&)>& fn) {
  for (auto& [id, tile] : tiles_) {
    if (tile.tree) {
      GS_RETURN_IF_ERROR(fn(id, *tile.tree));
      continue;
    }
    Tile loaded;
    GS_RETURN_IF_ERROR(Load(id, &loaded));
    GS_RETURN_IF_ERROR(fn(id, *loaded.tree));
  }
  return Status::Ok();
}

void TiledFusion::TileBounds(uint64_t tile_id, Eigen::Vector3d* min, Eigen::Vector3d* max) const {
  const Codec codec(options_.tile_bits);
  const octomap::OcTreeKey low = codec.Decode(tile_id << (3 * codec.k));
  const octomap::OcTreeKey high = codec.Decode((tile_id << (3 * codec.k)) | ((uint64_t{1} << (3 * codec.k)) - 1));
  const double half = 0.5 * options_.resolution;
  for (int a = 0; a < 3; ++a) {
    (*min)[a] = keyer_->keyToCoord(low[a]) - half;
    (*max)[a] = keyer_->keyToCoord(high[a]) + half;
  }
}

}  // namespace graphslam::map
