// CompactObservations: a list of planar observations (core::Observation) at
// 32 bytes each instead of 80, for the sample the sampled incremental start
// holds whole (partition/initialization/sampled_incremental_initialization.h:
// 24 observations per pose, 24e6 at 10^6 poses).
//
// A record keeps pose, feature, z (two doubles, unaligned), the input line
// and an index into a table of the distinct (model kind, information) pairs
// shared by all records: a front end's information matrices come from a few
// sensor noise models, so the table stays a few entries long. Distinct means
// bit-for-bit, so operator[] returns exactly the observation pushed (the
// starts solved from the sample are the same as from core::Observation).
// With an information matrix per observation the table grows with the list
// (32 + 40 bytes and a hash-table slot per observation): no saving then.
//
// THREAD SAFETY: a plain value; const members may run concurrently.
// ALLOCATION: 32 bytes per observation plus the table.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "core/problem.h"

namespace graphslam::partition {

class CompactObservations {
 public:
  void reserve(size_t n) { records_.reserve(n); }
  size_t size() const { return records_.size(); }
  bool empty() const { return records_.empty(); }
  // Frees the records and the table.
  void Release();

  void push_back(const core::Observation& o);
  // The observation pushed k-th, bit for bit.
  core::Observation operator[](size_t k) const;
  int32_t pose(size_t k) const { return records_[k].pose; }
  int32_t feature(size_t k) const { return records_[k].feature; }

  // Distinct (kind, information) pairs so far.
  size_t table_size() const { return table_.size(); }

 private:
  struct Record {
    int32_t pose;
    int32_t feature;
    double z[2];
    int32_t model;  // into table_
    int32_t line;
  };
  static_assert(sizeof(Record) == 32);
  struct Model {
    core::ObservationKind kind;
    Eigen::Matrix2d information;
  };
  // The key of a model: its kind and the information's bits.
  using Key = std::array<uint64_t, 5>;
  struct KeyHash {
    size_t operator()(const Key& key) const;
  };

  std::vector<Record> records_;
  std::vector<Model> table_;
  std::unordered_map<Key, int32_t, KeyHash> index_;  // Key -> into table_
};

}  // namespace graphslam::partition
