// CompactObservations (partition/initialization/compact_observations.h):
// every observation comes back bit for bit (pose, feature, kind, z,
// information, line), the (kind, information) table holds each distinct pair
// once however many observations share it (a kind or a single bit apart,
// -0.0 against 0.0, is another pair), and Release empties the list.
#include "partition/initialization/compact_observations.h"

#include <gtest/gtest.h>

#include <bit>
#include <cstring>
#include <random>
#include <vector>

namespace graphslam::partition {
namespace {

bool SameBits(const core::Observation& a, const core::Observation& b) {
  auto bits = [](double x) { return std::bit_cast<uint64_t>(x); };
  if (a.pose != b.pose || a.feature != b.feature || a.kind != b.kind || a.line != b.line)
    return false;
  for (int i = 0; i < 2; ++i)
    if (bits(a.z(i)) != bits(b.z(i))) return false;
  for (int i = 0; i < 4; ++i)
    if (bits(a.information.data()[i]) != bits(b.information.data()[i])) return false;
  return true;
}

TEST(CompactObservations, ReturnsEachObservationBitForBit) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uniform(-50.0, 50.0);
  std::uniform_int_distribution<int> pick(0, 3), index(0, 1 << 20);
  // Four models: two range-bearing noises, a point model, and a copy of the
  // first whose off-diagonal is -0.0 (another model bit for bit).
  std::vector<std::pair<core::ObservationKind, Eigen::Matrix2d>> models;
  models.push_back({core::ObservationKind::kRangeBearing,
                    Eigen::Vector2d(100.0, 2500.0).asDiagonal()});
  models.push_back({core::ObservationKind::kRangeBearing,
                    Eigen::Vector2d(25.0, 900.0).asDiagonal()});
  Eigen::Matrix2d full;
  full << 4.0, 0.5, 0.5, 3.0;
  models.push_back({core::ObservationKind::kPointXY, full});
  Eigen::Matrix2d negative_zero = models[0].second;
  negative_zero(0, 1) = -0.0;
  models.push_back({core::ObservationKind::kRangeBearing, negative_zero});

  std::vector<core::Observation> input;
  CompactObservations compact;
  for (int k = 0; k < 5000; ++k) {
    core::Observation o;
    o.pose = index(rng);
    o.feature = index(rng);
    const auto& model = models[static_cast<size_t>(pick(rng))];
    o.kind = model.first;
    o.information = model.second;
    o.z = Eigen::Vector2d(uniform(rng), uniform(rng));
    o.line = k + 1;
    input.push_back(o);
    compact.push_back(o);
  }
  ASSERT_EQ(compact.size(), input.size());
  EXPECT_EQ(compact.table_size(), models.size());
  for (size_t k = 0; k < input.size(); ++k) {
    ASSERT_TRUE(SameBits(compact[k], input[k])) << "observation " << k;
    EXPECT_EQ(compact.pose(k), input[k].pose);
    EXPECT_EQ(compact.feature(k), input[k].feature);
  }
  compact.Release();
  EXPECT_TRUE(compact.empty());
  EXPECT_EQ(compact.table_size(), 0u);
}

TEST(CompactObservations, AKindApartIsAnotherModel) {
  core::Observation a, b;
  a.kind = core::ObservationKind::kRangeBearing;
  b.kind = core::ObservationKind::kPointXY;  // same (identity) information
  CompactObservations compact;
  compact.push_back(a);
  compact.push_back(b);
  compact.push_back(a);
  EXPECT_EQ(compact.table_size(), 2u);
  EXPECT_EQ(compact[1].kind, core::ObservationKind::kPointXY);
  EXPECT_EQ(compact[2].kind, core::ObservationKind::kRangeBearing);
}

}  // namespace
}  // namespace graphslam::partition
