#include "partition/initialization/compact_observations.h"

#include <bit>

#include "core/check.h"

namespace graphslam::partition {

size_t CompactObservations::KeyHash::operator()(const Key& key) const {
  uint64_t h = 0x9E3779B97F4A7C15ULL;
  for (const uint64_t word : key) {
    h ^= word + 0x9E3779B97F4A7C15ULL + (h << 6) + (h >> 2);
  }
  return static_cast<size_t>(h);
}

void CompactObservations::Release() {
  std::vector<Record>().swap(records_);
  std::vector<Model>().swap(table_);
  std::unordered_map<Key, int32_t, KeyHash>().swap(index_);
}

void CompactObservations::push_back(const core::Observation& o) {
  const Key key = {static_cast<uint64_t>(o.kind), std::bit_cast<uint64_t>(o.information(0, 0)),
                   std::bit_cast<uint64_t>(o.information(1, 0)),
                   std::bit_cast<uint64_t>(o.information(0, 1)),
                   std::bit_cast<uint64_t>(o.information(1, 1))};
  const auto [it, inserted] = index_.try_emplace(key, static_cast<int32_t>(table_.size()));
  if (inserted) {
    GS_CHECK(table_.size() < static_cast<size_t>(INT32_MAX));
    table_.push_back({o.kind, o.information});
  }
  records_.push_back({o.pose, o.feature, {o.z.x(), o.z.y()}, it->second, o.line});
}

core::Observation CompactObservations::operator[](size_t k) const {
  const Record& r = records_[k];
  const Model& m = table_[static_cast<size_t>(r.model)];
  core::Observation o;
  o.pose = r.pose;
  o.feature = r.feature;
  o.kind = m.kind;
  o.z = Eigen::Vector2d(r.z[0], r.z[1]);
  o.information = m.information;
  o.line = r.line;
  return o;
}

}  // namespace graphslam::partition
