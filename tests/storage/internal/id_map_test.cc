// storage/internal/id_map.h: GrowingIdMap gives the mapping of a reference
// std::unordered_map for dense ids, sparse ids, negative and huge ids, and
// mixtures where sparse ids later fall inside the grown direct table.
#include "storage/internal/id_map.h"

#include <gtest/gtest.h>

#include <random>
#include <unordered_map>
#include <vector>

namespace graphslam::storage::internal {
namespace {

void ExpectSameAsReference(const std::vector<int64_t>& ids) {
  GrowingIdMap map;
  std::unordered_map<int64_t, int32_t> reference;
  for (const int64_t id : ids) {
    const auto it = reference.find(id);
    ASSERT_EQ(map.Find(id), it == reference.end() ? -1 : it->second) << id;
    if (it != reference.end()) continue;
    const auto index = static_cast<int32_t>(reference.size());
    reference.emplace(id, index);
    map.Insert(id, index);
    ASSERT_EQ(map.Find(id), index) << id;
  }
  EXPECT_EQ(map.size(), static_cast<int64_t>(reference.size()));
  for (const auto& [id, index] : reference) ASSERT_EQ(map.Find(id), index) << id;
  for (const int64_t absent : {int64_t{-7}, int64_t{1} << 40, int64_t{123456789}}) {
    if (reference.count(absent) == 0) {
      EXPECT_EQ(map.Find(absent), -1);
    }
  }
}

TEST(GrowingIdMapTest, MatchesAnUnorderedMapOnDenseSparseAndMixedIds) {
  std::mt19937_64 random(5);
  std::vector<int64_t> dense, sparse, mixed;
  for (int i = 0; i < 50000; ++i) dense.push_back(static_cast<int64_t>(random() % 120000));
  for (int i = 0; i < 20000; ++i)
    sparse.push_back(static_cast<int64_t>(random() >> 1) - (int64_t{1} << 62));
  // Large ids first (sparse while the map is small), then many small ones
  // that grow the table over them; repeats throughout.
  for (int i = 0; i < 100; ++i) mixed.push_back(100000 + static_cast<int64_t>(random() % 300000));
  for (int i = 0; i < 60000; ++i) mixed.push_back(static_cast<int64_t>(random() % 400000));
  for (int i = 0; i < 1000; ++i) mixed.push_back(-static_cast<int64_t>(random() % 1000));
  ExpectSameAsReference(dense);
  ExpectSameAsReference(sparse);
  ExpectSameAsReference(mixed);
}

}  // namespace
}  // namespace graphslam::storage::internal
