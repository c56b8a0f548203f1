// FindDuplicateFeatures: which pairs of map features are one landmark
// mapped twice (a split), by the correspondence test of Table 9 applied
// feature to feature, each pair accepted only when neither of its features
// has another compatible partner.
//
// Points: k features with means mu_0..mu_{k-1} and one dense joint
// covariance S (2k square; the features are correlated through the poses
// that saw them). For a candidate pair (a, b) the difference D = mu_a - mu_b
// has covariance
//   C = S_aa + S_bb - S_ab - S_ba,
// and the pair is compatible when D^T C^{-1} D <= chi2^{-1}(2) at normal z
// (partition/association/internal/chi_square.h). The answer is every
// compatible pair whose two features occur in no other compatible candidate
// pair: where tubes or trees stand closer than the gate is wide, a split
// fragment is compatible with two neighbours and is left alone rather than
// merged with the nearer one, since the nearer one is the wrong one as often
// as the error that caused the split points that way. The answer's pairs
// are disjoint.
//
// THREAD SAFETY: a pure function. ALLOCATION: O(candidates + k).
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace graphslam::partition {

struct DuplicateTestInput {
  std::vector<Eigen::Vector2d> means;                   // k features
  Eigen::MatrixXd covariance;                           // 2k square, same order
  std::vector<std::pair<int32_t, int32_t>> candidates;  // pairs to test (a != b)
};

struct DuplicateTestResult {
  std::vector<std::pair<int32_t, int32_t>> merges;  // compatible and unique, sorted
  int64_t compatible = 0;                           // compatible candidate pairs
};

DuplicateTestResult FindDuplicateFeatures(const DuplicateTestInput& input, double z);

// D^T C^{-1} D of one pair; +infinity when C is not positive definite.
double PairMahalanobisSquared(const DuplicateTestInput& input, int32_t a, int32_t b);

}  // namespace graphslam::partition
