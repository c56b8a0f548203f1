// IdMap: external integer ids (pose / feature ids of a log) -> dense indices,
// built once and then read, possibly by many threads at once.
//
// Open addressing with linear probing over a power-of-two table at most half
// full (Knuth's multiplicative hash, the top bits of id * 2^64/phi): one cache
// line per lookup in the common case, 16 bytes per slot, i.e. <= 32 bytes per
// id -- about half of std::unordered_map's node + bucket cost, and no pointer
// chasing. When the ids are 0..n-1 in order (the common pose case) no table is
// built at all.
//
// THREAD SAFETY: Find is const and safe from many threads after Build.
// ALLOCATION: the table, in Build.
#pragma once

#include <cstdint>
#include <vector>

namespace graphslam::storage::internal {

class IdMap {
 public:
  // `ids[i]` gets index i; ids must be distinct (the reader checked that).
  void Build(const std::vector<int64_t>& ids) {
    size_ = static_cast<int64_t>(ids.size());
    identity_ = true;
    for (int64_t i = 0; i < size_ && identity_; ++i) identity_ = ids[i] == i;
    keys_.clear();
    values_.clear();
    if (identity_) return;
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
};

}  // namespace graphslam::storage::internal
