// AssignChunks and SplitRows (distributed/chunk_assignment.h): contiguous,
// balanced, every chunk and row owned exactly once.
#include "distributed/chunk_assignment.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace graphslam::distributed {
namespace {

TEST(AssignChunks, EqualChunksSplitEvenly) {
  const std::vector<int64_t> observations(8, 100);
  EXPECT_EQ(AssignChunks(observations, 4), (std::vector<int>{0, 0, 1, 1, 2, 2, 3, 3}));
  EXPECT_EQ(AssignChunks(observations, 1), std::vector<int>(8, 0));
}

TEST(AssignChunks, ContiguousAndBalancedWithinOneChunk) {
  std::mt19937 random(7);
  std::uniform_int_distribution<int64_t> size(1, 1000);
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<int64_t> observations(200);
    for (int64_t& o : observations) o = size(random);
    const int ranks = 1 + trial % 7;
    const std::vector<int> owner = AssignChunks(observations, ranks);
    ASSERT_EQ(owner.size(), observations.size());
    EXPECT_TRUE(std::is_sorted(owner.begin(), owner.end()));  // contiguous ranges
    std::vector<int64_t> load(ranks, 0);
    int64_t total = 0;
    for (size_t k = 0; k < owner.size(); ++k) {
      ASSERT_GE(owner[k], 0);
      ASSERT_LT(owner[k], ranks);
      load[owner[k]] += observations[k];
      total += observations[k];
    }
    // Each share is T / N within one chunk (<= 1000 observations) either way.
    for (int r = 0; r < ranks; ++r) {
      EXPECT_NEAR(static_cast<double>(load[r]), static_cast<double>(total) / ranks, 1000.0)
          << "rank " << r << " of " << ranks;
    }
  }
}

TEST(AssignChunks, MoreRanksThanChunksLeavesSomeRanksWithout) {
  // Midpoints 5 and 15 of 20 fall into the shares of ranks 1 and 3.
  const std::vector<int> owner = AssignChunks({10, 10}, 4);
  EXPECT_EQ(owner, (std::vector<int>{1, 3}));
}

TEST(SplitRows, CoversEveryRowOnceAndOwnerInverts) {
  for (int ranks : {1, 2, 3, 4, 7}) {
    const std::vector<int> first = SplitRows(6969, ranks);
    ASSERT_EQ(first.size(), static_cast<size_t>(ranks) + 1);
    EXPECT_EQ(first.front(), 0);
    EXPECT_EQ(first.back(), 6969);
    for (int r = 0; r < ranks; ++r) {
      EXPECT_LE(first[r + 1] - first[r], 6969 / ranks + 1);
      EXPECT_GE(first[r + 1] - first[r], 6969 / ranks);
      for (int row = first[r]; row < first[r + 1]; row += 97) EXPECT_EQ(RowOwner(first, row), r);
      if (first[r + 1] > first[r]) {
        EXPECT_EQ(RowOwner(first, first[r + 1] - 1), r);
      }
    }
  }
}

}  // namespace
}  // namespace graphslam::distributed
