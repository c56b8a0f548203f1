#include "partition/association/duplicate_features.h"

#include <algorithm>
#include <limits>
#include <unordered_map>

#include <Eigen/Cholesky>

#include "partition/association/internal/chi_square.h"

namespace graphslam::partition {

double PairMahalanobisSquared(const DuplicateTestInput& input, int32_t a, int32_t b) {
  const Eigen::Vector2d d = input.means[a] - input.means[b];
  const Eigen::Matrix2d c =
      input.covariance.block<2, 2>(2 * a, 2 * a) + input.covariance.block<2, 2>(2 * b, 2 * b) -
      input.covariance.block<2, 2>(2 * a, 2 * b) - input.covariance.block<2, 2>(2 * b, 2 * a);
  const Eigen::LLT<Eigen::Matrix2d> llt(0.5 * (c + c.transpose()));
  if (llt.info() != Eigen::Success) return std::numeric_limits<double>::infinity();
  return d.dot(llt.solve(d));
}

DuplicateTestResult FindDuplicateFeatures(const DuplicateTestInput& input, double z) {
  DuplicateTestResult result;
  const double gate = internal::ChiSquareQuantile(2.0, z);
  std::vector<std::pair<int32_t, int32_t>> compatible;
  std::unordered_map<int32_t, int> partners;
  for (const auto& [a, b] : input.candidates) {
    if (a == b || !(PairMahalanobisSquared(input, a, b) <= gate)) continue;
    const auto pair = std::minmax(a, b);
    compatible.emplace_back(pair.first, pair.second);
  }
  // A pair listed twice (as (a, b) and (b, a)) is one partner, not two.
  std::sort(compatible.begin(), compatible.end());
  compatible.erase(std::unique(compatible.begin(), compatible.end()), compatible.end());
  for (const auto& [a, b] : compatible) {
    ++partners[a];
    ++partners[b];
  }
  result.compatible = static_cast<int64_t>(compatible.size());
  for (const auto& [a, b] : compatible)
    if (partners[a] == 1 && partners[b] == 1) result.merges.emplace_back(a, b);
  return result;
}

}  // namespace graphslam::partition
