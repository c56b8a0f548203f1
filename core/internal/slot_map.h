// SlotMap: dense slot numbers 0, 1, 2, ... for the distinct 64-bit keys of a
// short-lived working set, in order of first appearance; an open-addressing
// hash table (linear probing, Fibonacci hashing) that is emptied in
// O(keys inserted) so one object serves chunk after chunk.
//
// The per-chunk reduction (core/schur_eliminator.h, ReducedContribution)
// keys it with a pose pair (i << 32 | k) or a pose index, and keeps the sums
// of each slot in its own arrays: one lookup per term instead of one list
// entry per term that the serial merge has to walk again.
//
// THREAD SAFETY: none (one per worker). ALLOCATION: the table keeps its
// capacity across Clear(); it doubles when half full.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace graphslam::core::internal {

class SlotMap {
 public:
  static constexpr uint64_t kEmpty = ~uint64_t{0};  // never a key (pairs of ints >= 0)

  static uint64_t PairKey(int a, int b) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) | static_cast<uint32_t>(b);
  }

  // Forgets every key in O(keys inserted since the last Clear).
  void Clear() {
    for (size_t slot : used_) keys_[slot] = kEmpty;
    used_.clear();
  }

  size_t size() const { return used_.size(); }

  // The slot of `key` (!= kEmpty); *inserted tells whether it is new (then
  // its slot number is size() - 1).
  int32_t Find(uint64_t key, bool* inserted) {
    if (2 * (used_.size() + 1) > keys_.size()) Grow();
    size_t index = Home(key);
    while (keys_[index] != kEmpty) {
      if (keys_[index] == key) {
        *inserted = false;
        return slots_[index];
      }
      index = (index + 1) & mask_;
    }
    keys_[index] = key;
    slots_[index] = static_cast<int32_t>(used_.size());
    used_.push_back(index);
    *inserted = true;
    return slots_[index];
  }

 private:
  size_t Home(uint64_t key) const {
    return static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }

  void Grow() {
    const size_t capacity = keys_.empty() ? 1024 : 2 * keys_.size();
    // Re-insert in slot order, so slot numbers stay what they were.
    std::vector<uint64_t> keys(used_.size());
    for (size_t slot = 0; slot < used_.size(); ++slot) keys[slot] = keys_[used_[slot]];
    keys_.assign(capacity, kEmpty);
    slots_.assign(capacity, 0);
    mask_ = capacity - 1;
    shift_ = 64;
    for (size_t c = capacity; c > 1; c >>= 1) --shift_;
    used_.clear();
    for (size_t slot = 0; slot < keys.size(); ++slot) {
      size_t index = Home(keys[slot]);
      while (keys_[index] != kEmpty) index = (index + 1) & mask_;
      keys_[index] = keys[slot];
      slots_[index] = static_cast<int32_t>(slot);
      used_.push_back(index);
    }
  }

  std::vector<uint64_t> keys_;
  std::vector<int32_t> slots_;  // per table index: the key's slot number
  std::vector<size_t> used_;    // per slot number: its table index
  size_t mask_ = 0;
  int shift_ = 64;
};

}  // namespace graphslam::core::internal
