// SlotMap (core/internal/slot_map.h): slot numbers in order of first
// appearance, equal to a std::unordered_map reference over random keys with
// repeats, through several doublings of the table and across Clear() (one
// object serves chunk after chunk in the reduce pass).
#include "core/internal/slot_map.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <unordered_map>

namespace graphslam::core::internal {
namespace {

// Feeds `count` random pair keys (poses below `poses`, so keys repeat) and
// checks every answer against the reference numbering.
void ExpectSameAsReference(SlotMap* map, int count, int poses, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> pose(0, poses - 1);
  std::unordered_map<uint64_t, int32_t> reference;
  for (int n = 0; n < count; ++n) {
    const uint64_t key = SlotMap::PairKey(pose(rng), pose(rng));
    const auto [it, is_new] = reference.emplace(key, static_cast<int32_t>(reference.size()));
    bool inserted = false;
    const int32_t slot = map->Find(key, &inserted);
    ASSERT_EQ(inserted, is_new) << "key " << key << " at draw " << n;
    ASSERT_EQ(slot, it->second) << "key " << key << " at draw " << n;
  }
  EXPECT_EQ(map->size(), reference.size());
}

TEST(SlotMap, NumbersKeysInOrderOfFirstAppearanceThroughGrowth) {
  SlotMap map;
  // ~40 000 distinct pairs of 300 poses: the table doubles from 1024 many times.
  ExpectSameAsReference(&map, 60000, 300, 1);
  EXPECT_GT(map.size(), 20000u);
}

TEST(SlotMap, ClearForgetsEveryKeyAndNumbersFromZeroAgain) {
  SlotMap map;
  ExpectSameAsReference(&map, 5000, 100, 2);
  map.Clear();
  EXPECT_EQ(map.size(), 0u);
  bool inserted = false;
  EXPECT_EQ(map.Find(SlotMap::PairKey(7, 9), &inserted), 0);
  EXPECT_TRUE(inserted);
  map.Clear();
  // A different working set in the same (grown) table.
  ExpectSameAsReference(&map, 5000, 60, 3);
}

TEST(SlotMap, PairKeyTellsOrderedPairsApart) {
  EXPECT_NE(SlotMap::PairKey(1, 2), SlotMap::PairKey(2, 1));
  EXPECT_NE(SlotMap::PairKey(0, 1), SlotMap::PairKey(1, 0));
  EXPECT_NE(SlotMap::PairKey(2147483647, 0), SlotMap::kEmpty);
  EXPECT_NE(SlotMap::PairKey(2147483647, 2147483647), SlotMap::kEmpty);
}

}  // namespace
}  // namespace graphslam::core::internal
