// storage/internal/monotone_lines.h: every entry reads back as appended, for
// gaps of every varint length (0, < 128, < 2^14, < 2^21, up to 2^31 - 1),
// across group boundaries (64 entries) and page boundaries (64 KiB of
// deltas); and the common case (one new feature every ~10 lines) takes one
// byte of deltas per entry.
#include "storage/internal/monotone_lines.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <vector>

namespace graphslam::storage::internal {
namespace {

TEST(MonotoneLinesTest, ReadsBackEveryEntryForGapsOfEveryVarintLength) {
  std::mt19937 random(3);
  const std::vector<int32_t> largest_gap = {0, 127, 128, 16383, 16384, 2097151, 2097152};
  std::vector<int32_t> reference;
  MonotoneLines lines;
  lines.Reserve(300000);
  int32_t line = 1;
  for (int i = 0; i < 300000; ++i) {
    // Every 97th gap up to the next of largest_gap, the others below 128
    // (the sum stays within int32).
    const int32_t most =
        i % 97 == 0 ? largest_gap[static_cast<size_t>(i / 97) % largest_gap.size()] : 127;
    line += std::uniform_int_distribution<int32_t>(0, most)(random);
    lines.Append(line);
    reference.push_back(line);
  }
  // The last gaps reach the int32 range's end.
  for (const int32_t last : {std::numeric_limits<int32_t>::max() - 1,
                             std::numeric_limits<int32_t>::max()}) {
    lines.Append(last);
    reference.push_back(last);
  }
  ASSERT_EQ(lines.size(), static_cast<int64_t>(reference.size()));
  for (size_t i = 0; i < reference.size(); ++i)
    ASSERT_EQ(lines[static_cast<int64_t>(i)], reference[i]) << "entry " << i;
}

TEST(MonotoneLinesTest, TakesAboutOneByteOfDeltasPerEntryAtSmallGaps) {
  MonotoneLines lines;
  // 10^6 entries (~15 pages of deltas), gaps 0-127: one byte each.
  for (int32_t i = 0; i < 1000000; ++i) lines.Append(1 + 10 * i + (i % 7));
  EXPECT_EQ(lines[0], 1);
  EXPECT_EQ(lines[63], 1 + 630 + 0);
  EXPECT_EQ(lines[64], 1 + 640 + 1);
  EXPECT_EQ(lines[999999], 1 + 9999990 + 999999 % 7);
  EXPECT_EQ(lines.delta_bytes(), 1000000 - (1000000 + 63) / 64);
}

}  // namespace
}  // namespace graphslam::storage::internal
