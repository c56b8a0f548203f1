// IdMap: external integer ids (pose / feature ids of a log) -> dense indices,
// built once and then read, possibly by many threads at once.
//
// When the ids are 0..n-1 in order (the common pose case) no table is built
// at all. When they are non-negative and below 8 n + 1024 (dense integers: the
// simulator's feature ids are slot numbers, ~2-3 per observed feature) they
// index a direct table of int32 (4 bytes per table entry, ~10 per id there).
// Otherwise: open addressing with linear probing over a power-of-two table at
// most half full (Knuth's multiplicative hash, the top bits of id * 2^64/phi):
// one cache line per lookup in the common case, 12 bytes per slot, i.e. 24-48
// bytes per id. The direct table is what keeps the ingest's second pass at
// 10^8 world features (4.4*10^7 ids) at ~0.4 GB instead of 1.6 GB.
//
// THREAD SAFETY: Find is const and safe from many threads after Build.
// ALLOCATION: the table, in Build.
#pragma once

#include <algorithm>
#include <cstdint>
#include <unordered_map>
#include <vector>

namespace graphslam::storage::internal {

class IdMap {
 public:
  // `ids[i]` gets index i; ids must be distinct (the reader checked that).
  void Build(const std::vector<int64_t>& ids) {
    size_ = static_cast<int64_t>(ids.size());
    identity_ = true;
    for (int64_t i = 0; i < size_ && identity_; ++i) identity_ = ids[i] == i;
    keys_ = std::vector<int64_t>();
    values_ = std::vector<int32_t>();
    direct_ = std::vector<int32_t>();
    if (identity_) return;
    const auto [low, high] = std::minmax_element(ids.begin(), ids.end());
    if (*low >= 0 && *high < 8 * size_ + 1024) {
      direct_.assign(static_cast<size_t>(*high) + 1, -1);
      for (size_t i = 0; i < ids.size(); ++i)
        direct_[static_cast<size_t>(ids[i])] = static_cast<int32_t>(i);
      return;
    }
    shift_ = 64;
    size_t capacity = 1;
    while (capacity < 2 * ids.size() + 2) {
      capacity <<= 1;
      --shift_;
    }
    keys_.assign(capacity, 0);
    values_.assign(capacity, -1);
    for (size_t i = 0; i < ids.size(); ++i) {
      size_t slot = Slot(ids[i]);
      while (values_[slot] >= 0) slot = (slot + 1) & (capacity - 1);
      keys_[slot] = ids[i];
      values_[slot] = static_cast<int32_t>(i);
    }
  }

  // The index of `id`, or -1.
  int32_t Find(int64_t id) const {
    if (identity_) return id >= 0 && id < size_ ? static_cast<int32_t>(id) : -1;
    if (!direct_.empty())
      return id >= 0 && id < static_cast<int64_t>(direct_.size()) ? direct_[id] : -1;
    const size_t mask = keys_.size() - 1;
    for (size_t slot = Slot(id);; slot = (slot + 1) & mask) {
      if (values_[slot] < 0) return -1;
      if (keys_[slot] == id) return values_[slot];
    }
  }

 private:
  size_t Slot(int64_t id) const {
    return static_cast<size_t>((static_cast<uint64_t>(id) * 0x9E3779B97F4A7C15ull) >> shift_);
  }

  int64_t size_ = 0;
  bool identity_ = true;
  int shift_ = 64;
  std::vector<int64_t> keys_;
  std::vector<int32_t> values_;
  std::vector<int32_t> direct_;  // dense ids: id -> index, -1: not there
};

// GrowingIdMap: the same mapping built one id at a time, as a reader meets
// the ids. Ids in [0, 8 * size + 1024) go to a direct table (4 bytes per
// table entry, no hashing): the ids of a log are usually dense integers (the
// simulator's are slot numbers, ~2-3 per observed feature), and there it
// costs ~10 bytes per id against ~48 for std::unordered_map's node and
// bucket, which was a quarter of the ingest's first pass at 10^7 features.
// Other ids (negative, huge, sparse) go to an unordered_map. An id lives in
// exactly one of the two.
//
// THREAD SAFETY: none (one reader). ALLOCATION: the table (resident: up to
// the highest dense id seen; capacity doubling) and the map's nodes.
class GrowingIdMap {
 public:
  // The index of `id`, or -1.
  int32_t Find(int64_t id) const {
    if (id >= 0 && id < static_cast<int64_t>(direct_.size()) && direct_[id] >= 0)
      return direct_[id];
    if (sparse_.empty()) return -1;
    const auto it = sparse_.find(id);
    return it == sparse_.end() ? -1 : it->second;
  }
  // Adds id -> index; `id` must not be in the map (Find(id) == -1).
  void Insert(int64_t id, int32_t index) {
    ++size_;
    const int64_t dense_limit = 8 * size_ + 1024;
    if (id >= 0 && id < dense_limit) {
      // To the id only: std::vector's own growth is geometric (amortized
      // O(1)) and leaves its spare capacity unwritten, i.e. not resident;
      // doubling the size here filled it with -1 (up to 2x the id range).
      if (id >= static_cast<int64_t>(direct_.size()))
        direct_.resize(static_cast<size_t>(id) + 1, -1);
      direct_[id] = index;
    } else {
      sparse_.emplace(id, index);
    }
    // The dense limit grows with the size: at every doubling the hashed ids
    // now below it move to the table. A log whose first ids are high (a
    // store's features, in first-sight order, are spread over the id range)
    // would otherwise keep them hashed for good (~70 bytes per id).
    if (!sparse_.empty() && (size_ & (size_ - 1)) == 0) MoveDenseIdsToTheTable(dense_limit);
  }
  int64_t size() const { return size_; }
  // Ids [0, id_end) of `count` ids will be inserted: the direct table's
  // capacity, if the ids are dense enough for it (as Insert decides once all
  // are in), so it never grows by copying.
  void ReserveDirect(int64_t id_end, int64_t count) {
    if (id_end < 8 * count + 1024) direct_.reserve(static_cast<size_t>(id_end));
  }

 private:
  void MoveDenseIdsToTheTable(int64_t dense_limit) {
    for (auto it = sparse_.begin(); it != sparse_.end();) {
      if (it->first >= 0 && it->first < dense_limit) {
        if (it->first >= static_cast<int64_t>(direct_.size()))
          direct_.resize(static_cast<size_t>(it->first) + 1, -1);
        direct_[it->first] = it->second;
        it = sparse_.erase(it);
      } else {
        ++it;
      }
    }
    // Rehash to the entries left: an emptied table's buckets stay allocated.
    sparse_.rehash(0);
  }

  int64_t size_ = 0;
  std::vector<int32_t> direct_;  // id -> index, -1: not there
  std::unordered_map<int64_t, int32_t> sparse_;
};

}  // namespace graphslam::storage::internal
