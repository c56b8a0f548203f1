// The distinct pairs (a, b) among many insertions, in O(insertions): an
// open-addressing hash set of the 64-bit keys (min(a, b), max(a, b)) that
// appends a pair to the caller's list the first time it is seen. The pattern
// of the reduced matrix is collected per chunk with it (core/chunk_passes.cc):
// the sort + unique of every chunk's pair list it replaces was 14 % of the CPU
// of a one-iteration streaming solve (perf, store1e7,
// docs/history/benchmarks-notebook-2026-11.md).
//
// The order of the emitted pairs is the order of first insertion; the set of
// pairs equals sort + unique of all insertions.
//
// THREAD SAFETY: none (one per worker). ALLOCATION: the table keeps its
// capacity across Clear(); it doubles when half full.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

namespace graphslam::core::internal {

class PosePairSet {
 public:
  // Empties the set in O(pairs inserted since the last Clear).
  void Clear() {
    for (size_t slot : used_) slots_[slot] = kEmpty;
    used_.clear();
  }

  // Appends (min(a, b), max(a, b)) to *out unless already in the set.
  // a, b >= 0.
  void Insert(int a, int b, std::vector<std::pair<int, int>>* out) {
    if (a > b) std::swap(a, b);
    const uint64_t key = (static_cast<uint64_t>(static_cast<uint32_t>(a)) << 32) |
                         static_cast<uint32_t>(b);
    if (2 * (used_.size() + 1) > slots_.size()) Grow();
    size_t slot = Home(key);
    while (slots_[slot] != kEmpty) {
      if (slots_[slot] == key) return;
      slot = (slot + 1) & mask_;
    }
    slots_[slot] = key;
    used_.push_back(slot);
    out->emplace_back(a, b);
  }

 private:
  static constexpr uint64_t kEmpty = ~uint64_t{0};  // no pair of ints >= 0 has this key

  size_t Home(uint64_t key) const {
    // Fibonacci hashing: the high bits of key * 2^64 / phi.
    return static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift_);
  }

  void Grow() {
    const size_t capacity = slots_.empty() ? 1024 : 2 * slots_.size();
    std::vector<uint64_t> keys;
    keys.reserve(used_.size());
    for (size_t slot : used_) keys.push_back(slots_[slot]);
    slots_.assign(capacity, kEmpty);
    mask_ = capacity - 1;
    shift_ = 64;
    for (size_t c = capacity; c > 1; c >>= 1) --shift_;
    used_.clear();
    for (uint64_t key : keys) {
      size_t slot = Home(key);
      while (slots_[slot] != kEmpty) slot = (slot + 1) & mask_;
      slots_[slot] = key;
      used_.push_back(slot);
    }
  }

  std::vector<uint64_t> slots_;
  std::vector<size_t> used_;  // occupied slots, for Clear and Grow
  size_t mask_ = 0;
  int shift_ = 64;
};

}  // namespace graphslam::core::internal
