// Tests of FindDuplicateFeatures (partition/association/duplicate_features.h):
// the pair distance equals the dense reference D^T (J S J^T)^{-1} D, a split
// landmark is merged, a fragment compatible with two neighbours is not, and
// the merges are exactly the compatible pairs whose features have no other
// compatible partner (checked against counting every pair on random maps).
#include "partition/association/duplicate_features.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>

#include "partition/association/internal/chi_square.h"

namespace graphslam::partition {
namespace {

// Features at `means` with independent isotropic covariances sigma^2 I plus
// a common shift of variance shared^2 (the poses they share).
DuplicateTestInput IsotropicMap(const std::vector<Eigen::Vector2d>& means, double sigma,
                                double shared) {
  DuplicateTestInput input;
  input.means = means;
  const int k = static_cast<int>(means.size());
  input.covariance = Eigen::MatrixXd::Constant(2 * k, 2 * k, 0.0);
  for (int a = 0; a < k; ++a)
    for (int b = 0; b < k; ++b)
      input.covariance.block<2, 2>(2 * a, 2 * b) =
          (shared * shared + (a == b ? sigma * sigma : 0.0)) * Eigen::Matrix2d::Identity();
  return input;
}

TEST(DuplicateFeatures, PairDistanceMatchesDenseReference) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const int k = 4;
    DuplicateTestInput input;
    for (int i = 0; i < k; ++i) input.means.emplace_back(noise(rng), noise(rng));
    Eigen::MatrixXd a(2 * k, 2 * k);
    for (int r = 0; r < 2 * k; ++r)
      for (int c = 0; c < 2 * k; ++c) a(r, c) = 0.3 * noise(rng);
    input.covariance = a * a.transpose() + 0.01 * Eigen::MatrixXd::Identity(2 * k, 2 * k);
    for (int x = 0; x < k; ++x) {
      for (int y = 0; y < k; ++y) {
        if (x == y) continue;
        Eigen::MatrixXd j = Eigen::MatrixXd::Zero(2, 2 * k);
        j.block<2, 2>(0, 2 * x) = Eigen::Matrix2d::Identity();
        j.block<2, 2>(0, 2 * y) = -Eigen::Matrix2d::Identity();
        const Eigen::Vector2d d = input.means[x] - input.means[y];
        const Eigen::MatrixXd c = j * input.covariance * j.transpose();
        const double reference = d.dot(c.inverse() * d);
        EXPECT_NEAR(PairMahalanobisSquared(input, x, y), reference, 1e-9 * (1.0 + reference));
      }
    }
  }
}

TEST(DuplicateFeatures, SplitLandmarkIsMergedAndAmbiguousFragmentIsNot) {
  // Features 0 and 1: one landmark seen twice, 0.15 m apart with sigma 0.1;
  // feature 2: another landmark 2 m away; feature 3: a fragment 0.3 m from
  // both 4 and 5, which stand 0.6 m apart (two tubes and a fragment between).
  const DuplicateTestInput input = IsotropicMap(
      {{0.0, 0.0}, {0.15, 0.0}, {2.0, 0.0}, {5.3, 0.0}, {5.0, 0.0}, {5.6, 0.0}}, 0.1, 0.5);
  DuplicateTestInput tested = input;
  tested.candidates = {{1, 0}, {1, 2}, {3, 4}, {3, 5}, {0, 1}};
  const DuplicateTestResult result = FindDuplicateFeatures(tested, 3.1368);
  ASSERT_EQ(result.merges.size(), 1u);
  EXPECT_EQ(result.merges[0], std::make_pair(0, 1));
  EXPECT_EQ(result.compatible, 3);  // (0, 1) once, (3, 4), (3, 5)
}

TEST(DuplicateFeatures, SharedShiftDoesNotWidenTheGate) {
  // A common shift (pose uncertainty both features share) cancels in the
  // difference: 1 m apart with sigma 0.1 is not compatible however large it is.
  DuplicateTestInput input = IsotropicMap({{0.0, 0.0}, {1.0, 0.0}}, 0.1, 10.0);
  input.candidates = {{0, 1}};
  EXPECT_TRUE(FindDuplicateFeatures(input, 3.1368).merges.empty());
  EXPECT_NEAR(PairMahalanobisSquared(input, 0, 1), 1.0 / 0.02, 1e-6);
}

TEST(DuplicateFeatures, NonPositiveDefiniteDifferenceIsNeverCompatible) {
  DuplicateTestInput input = IsotropicMap({{0.0, 0.0}, {0.0, 0.0}}, 0.0, 1.0);
  input.candidates = {{0, 1}};
  EXPECT_TRUE(std::isinf(PairMahalanobisSquared(input, 0, 1)));
  EXPECT_TRUE(FindDuplicateFeatures(input, 3.1368).merges.empty());
}

TEST(DuplicateFeatures, MergesAreTheUniqueCompatiblePairs) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> place(0.0, 3.0);
  const double gate = internal::ChiSquareQuantile(2.0, 3.1368);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<Eigen::Vector2d> means;
    for (int i = 0; i < 8; ++i) means.emplace_back(place(rng), place(rng));
    DuplicateTestInput input = IsotropicMap(means, 0.15, 0.3);
    for (int a = 0; a < 8; ++a)
      for (int b = 0; b < 8; ++b)
        if (a != b && rng() % 2 == 0) input.candidates.emplace_back(a, b);
    const DuplicateTestResult result = FindDuplicateFeatures(input, 3.1368);
    // Reference: count every compatible unordered candidate pair.
    std::vector<std::pair<int32_t, int32_t>> compatible;
    for (const auto& [a, b] : input.candidates)
      if (PairMahalanobisSquared(input, a, b) <= gate)
        compatible.push_back(std::minmax(a, b));
    std::sort(compatible.begin(), compatible.end());
    compatible.erase(std::unique(compatible.begin(), compatible.end()), compatible.end());
    std::vector<int> partners(8, 0);
    for (const auto& [a, b] : compatible) ++partners[a], ++partners[b];
    std::vector<std::pair<int32_t, int32_t>> expected;
    for (const auto& [a, b] : compatible)
      if (partners[a] == 1 && partners[b] == 1) expected.emplace_back(a, b);
    EXPECT_EQ(result.merges, expected);
    EXPECT_EQ(result.compatible, static_cast<int64_t>(compatible.size()));
    std::vector<int> used(8, 0);
    for (const auto& [a, b] : result.merges) EXPECT_EQ(++used[a] + ++used[b], 2);
  }
}

}  // namespace
}  // namespace graphslam::partition
