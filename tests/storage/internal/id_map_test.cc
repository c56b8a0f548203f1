// storage/internal/id_map.h: GrowingIdMap gives the mapping of a reference
// std::unordered_map for dense ids, sparse ids, negative and huge ids, and
// mixtures where sparse ids later fall inside the grown direct table; IdMap
// (built at once) gives it too, through its identity, direct and hashed forms.
#include "storage/internal/id_map.h"

#include <gtest/gtest.h>

#include <algorithm>
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

// Distinct ids in input order: identity (0..n-1), dense (direct table: ids
// spread over ~3x their count, as the simulator's), sparse and negative
// (hashed), and dense with one huge id (hashed).
TEST(IdMapTest, MatchesTheIdsPositionsInEveryForm) {
  std::mt19937_64 random(9);
  std::vector<int64_t> identity, dense, sparse, dense_but_one;
  for (int64_t i = 0; i < 5000; ++i) identity.push_back(i);
  std::vector<int64_t> slots(30000);
  for (int64_t i = 0; i < 30000; ++i) slots[i] = i;
  std::shuffle(slots.begin(), slots.end(), random);
  dense.assign(slots.begin(), slots.begin() + 10000);
  for (int i = 0; i < 10000; ++i)
    sparse.push_back(static_cast<int64_t>(random() >> 1) - (int64_t{1} << 62));
  dense_but_one = dense;
  dense_but_one.push_back(int64_t{1} << 40);
  for (const std::vector<int64_t>* ids : {&identity, &dense, &sparse, &dense_but_one}) {
    IdMap map;
    map.Build(*ids);
    std::unordered_map<int64_t, int32_t> reference;
    for (size_t i = 0; i < ids->size(); ++i) reference.emplace((*ids)[i], static_cast<int32_t>(i));
    ASSERT_EQ(reference.size(), ids->size()) << "ids must be distinct";
    for (size_t i = 0; i < ids->size(); ++i)
      ASSERT_EQ(map.Find((*ids)[i]), static_cast<int32_t>(i)) << (*ids)[i];
    for (int64_t absent : {int64_t{-1}, int64_t{-7}, int64_t{29999}, int64_t{30000},
                           int64_t{123456789}, int64_t{1} << 41}) {
      if (reference.count(absent) == 0) {
        EXPECT_EQ(map.Find(absent), -1) << absent;
      }
    }
    for (int64_t probe = 0; probe < 40000; ++probe) {
      const auto it = reference.find(probe);
      ASSERT_EQ(map.Find(probe), it == reference.end() ? -1 : it->second) << probe;
    }
  }
}

}  // namespace
}  // namespace graphslam::storage::internal
