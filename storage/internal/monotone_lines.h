// MonotoneLines: a non-decreasing sequence of line numbers, kept in ~1-2
// bytes per entry instead of 4. A reader assigns dense feature indices in
// file order, so the line where each feature was declared or first used
// grows with its index; the line is read back only for an error message
// (a second FEATURE record, or one after the feature's first use).
//
// Encoding: entries in groups of 64; per group the first line (int32) and the
// byte offset of the group's deltas (int64), ~0.19 B per entry; every other
// entry is the difference d_i = line_i - line_{i-1} >= 0 as an LEB128 varint
// (7 bits per byte: one byte when d < 128, which is the usual gap between two
// new features of a log). The bytes live in pages of 64 KiB, so growing
// never copies them (no moment with an old and a new array both resident)
// and leaves at most one page unused.
//
// Cost: Append O(1); operator[] decodes at most 63 varints.
// THREAD SAFETY: none (one reader's state).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/status.h"

namespace graphslam::storage::internal {

class MonotoneLines {
 public:
  // Room for `entries` entries' group headers (the pages grow by themselves).
  void Reserve(int64_t entries) {
    const auto groups = static_cast<size_t>((entries + kGroup - 1) / kGroup);
    group_first_.reserve(groups);
    group_offset_.reserve(groups);
  }

  // `line` must be at least the last appended one.
  void Append(int32_t line) {
    if (size_ % kGroup == 0) {
      group_first_.push_back(line);
      group_offset_.push_back(bytes_);
    } else {
      GS_CHECK(line >= last_);
      auto delta = static_cast<uint32_t>(line - last_);
      while (delta >= 0x80) {
        PutByte(static_cast<uint8_t>(delta | 0x80));
        delta >>= 7;
      }
      PutByte(static_cast<uint8_t>(delta));
    }
    last_ = line;
    ++size_;
  }

  int32_t operator[](int64_t i) const {
    GS_CHECK(i >= 0 && i < size_);
    const auto group = static_cast<size_t>(i / kGroup);
    int32_t line = group_first_[group];
    int64_t offset = group_offset_[group];
    for (int64_t k = group * int64_t{kGroup}; k < i; ++k) {
      uint32_t delta = 0;
      for (int shift = 0;; shift += 7) {
        const uint8_t byte = Byte(offset++);
        delta |= static_cast<uint32_t>(byte & 0x7f) << shift;
        if ((byte & 0x80) == 0) break;
      }
      line += static_cast<int32_t>(delta);
    }
    return line;
  }

  int64_t size() const { return size_; }
  int64_t delta_bytes() const { return bytes_; }

 private:
  static constexpr int64_t kGroup = 64;
  static constexpr int kPageBits = 16;
  static constexpr int64_t kPageBytes = int64_t{1} << kPageBits;

  void PutByte(uint8_t byte) {
    if (bytes_ % kPageBytes == 0) pages_.push_back(std::make_unique<uint8_t[]>(kPageBytes));
    pages_.back()[static_cast<size_t>(bytes_ % kPageBytes)] = byte;
    ++bytes_;
  }
  uint8_t Byte(int64_t offset) const {
    return pages_[static_cast<size_t>(offset >> kPageBits)][static_cast<size_t>(offset % kPageBytes)];
  }

  std::vector<int32_t> group_first_;
  std::vector<int64_t> group_offset_;
  std::vector<std::unique_ptr<uint8_t[]>> pages_;
  int64_t bytes_ = 0;
  int64_t size_ = 0;
  int32_t last_ = 0;
};

}  // namespace graphslam::storage::internal
