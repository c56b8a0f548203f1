// Tests of AssignScanJointly (partition/association/joint_compatibility.h): the branch and
// bound finds the hypothesis that enumerating every exclusive assignment
// finds (most pairings whose every prefix is jointly compatible, then the
// smallest joint distance), and two observations never share a target.
#include "partition/association/joint_compatibility.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <functional>
#include <random>

#include "partition/association/internal/chi_square.h"

namespace graphslam::partition {
namespace {

// A random scan: targets on a small patch, observations near some of them
// (and some anywhere), a random positive definite joint covariance.
ScanAssociationInput RandomScan(std::mt19937* rng, int n, int m) {
  std::uniform_real_distribution<double> place(-2.0, 2.0);
  std::normal_distribution<double> noise(0.0, 0.3);
  ScanAssociationInput input;
  input.observations = n;
  input.targets = m;
  std::vector<Eigen::Vector2d> targets(m);
  for (auto& t : targets) t = Eigen::Vector2d(place(*rng), place(*rng));
  for (int i = 0; i < n; ++i) {
    if (m > 0 && (*rng)() % 4 != 0)
      input.means.push_back(targets[(*rng)() % m] + Eigen::Vector2d(noise(*rng), noise(*rng)));
    else
      input.means.push_back(Eigen::Vector2d(place(*rng), place(*rng)));
  }
  for (const auto& t : targets) input.means.push_back(t);
  const int d = 2 * (n + m);
  Eigen::MatrixXd a(d, d);
  for (int r = 0; r < d; ++r)
    for (int c = 0; c < d; ++c) a(r, c) = 0.15 * noise(*rng);
  input.covariance = a * a.transpose() + 0.05 * Eigen::MatrixXd::Identity(d, d);
  return input;
}

// Every exclusive partial assignment, kept when each pair is individually
// compatible and every prefix (observations 0..i) is jointly compatible.
ScanAssignment BruteForce(const ScanAssociationInput& input, double z) {
  const int n = input.observations;
  const double single_gate = internal::ChiSquareQuantile(2.0, z);
  ScanAssignment best;
  best.target.assign(n, -1);
  std::vector<int32_t> current(n, -1);
  std::vector<uint8_t> used(input.targets, 0);
  std::function<void(int)> visit = [&](int i) {
    if (i == n) {
      int pairings = 0;
      std::vector<int32_t> prefix(n, -1);
      for (int k = 0; k < n; ++k) {
        if (current[k] < 0) continue;
        std::vector<int32_t> single(n, -1);
        single[k] = current[k];
        if (JointMahalanobisSquared(input, single) > single_gate) return;
        prefix[k] = current[k];
        ++pairings;
        if (JointMahalanobisSquared(input, prefix) >
            internal::ChiSquareQuantile(2.0 * pairings, z))
          return;
      }
      const double d2 = JointMahalanobisSquared(input, current);
      if (pairings > best.pairings ||
          (pairings == best.pairings && d2 < best.mahalanobis_squared)) {
        best.target = current;
        best.pairings = pairings;
        best.mahalanobis_squared = d2;
      }
      return;
    }
    visit(i + 1);
    for (int a = 0; a < input.targets; ++a) {
      if (used[a]) continue;
      used[a] = 1;
      current[i] = a;
      visit(i + 1);
      current[i] = -1;
      used[a] = 0;
    }
  };
  visit(0);
  return best;
}

TEST(JointCompatibility, MatchesBruteForceOnSmallRandomScans) {
  std::mt19937 rng(7);
  JointCompatibilityOptions options;
  int with_pairings = 0, with_new = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 5);
    const int m = static_cast<int>(rng() % 6);
    const ScanAssociationInput input = RandomScan(&rng, n, m);
    const ScanAssignment expected = BruteForce(input, options.z);
    const ScanAssignment found = AssignScanJointly(input, options);
    SCOPED_TRACE("trial " + std::to_string(trial) + ", n " + std::to_string(n) + ", m " +
                 std::to_string(m));
    ASSERT_FALSE(found.exhausted);
    EXPECT_EQ(found.pairings, expected.pairings);
    EXPECT_EQ(found.target, expected.target);
    EXPECT_NEAR(found.mahalanobis_squared, expected.mahalanobis_squared, 1e-9);
    if (found.pairings > 0) ++with_pairings;
    if (found.pairings < n) ++with_new;
  }
  // The random scans exercise both outcomes.
  EXPECT_GT(with_pairings, 100);
  EXPECT_GT(with_new, 100);
}

TEST(JointCompatibility, TwoObservationsNeverShareATarget) {
  // Two observations both right on one target, one other target far off.
  ScanAssociationInput input;
  input.observations = 2;
  input.targets = 2;
  input.means = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.05, 0.0), Eigen::Vector2d(0.0, 0.0),
                 Eigen::Vector2d(30.0, 0.0)};
  input.covariance = 0.1 * Eigen::MatrixXd::Identity(8, 8);
  const ScanAssignment found = AssignScanJointly(input, JointCompatibilityOptions());
  EXPECT_EQ(found.pairings, 1);
  EXPECT_NE(found.target[0], found.target[1]);
  EXPECT_TRUE(found.target[0] == 0 || found.target[1] == 0);
  EXPECT_EQ(found.target[0] == 0 ? found.target[1] : found.target[0], -1);
}

TEST(JointCompatibility, SharedPoseErrorIsResolvedJointly) {
  // The scan is shifted by 0.8 m as a whole (its pose is off): each
  // observation alone lies nearer the wrong neighbour, but the covariance says
  // the shift is common, so the joint test prefers the consistent pairing.
  ScanAssociationInput input;
  input.observations = 2;
  input.targets = 3;
  const Eigen::Vector2d shift(0.8, 0.0);
  input.means = {Eigen::Vector2d(0.0, 0.0) + shift, Eigen::Vector2d(0.0, 3.0) + shift,
                 Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.0, 3.0), Eigen::Vector2d(1.5, 0.0)};
  Eigen::MatrixXd s = 0.01 * Eigen::MatrixXd::Identity(10, 10);
  // Observations share a 0.6 m pose error along x: Cov(o_i, o_j) += 0.36 I_x.
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) s(2 * i, 2 * j) += 0.36;
  input.covariance = s;
  const ScanAssignment found = AssignScanJointly(input, JointCompatibilityOptions());
  EXPECT_EQ(found.target, (std::vector<int32_t>{0, 1}));
}

}  // namespace
}  // namespace graphslam::partition
