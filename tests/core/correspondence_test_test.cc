// Tests of the Table 9 correspondence test (core/correspondence_test.h) and of
// the covariance column blocks (core/pose_marginals.h) against dense math.
#include "core/correspondence_test.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <random>

#include "core/pose_marginals.h"
#include "tests/testing/random_linear_system.h"

namespace graphslam::core {
namespace {

Eigen::Matrix4d RandomCovariance(uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Matrix4d a;
  for (int i = 0; i < 16; ++i) a.data()[i] = normal(rng);
  return a * a.transpose() + 0.1 * Eigen::Matrix4d::Identity();
}

// The density of N(mu, Sigma) at 0, straight from its definition.
double DenseDensityAtZero(const Eigen::Vector2d& mu, const Eigen::Matrix2d& sigma) {
  const double norm = 1.0 / (2.0 * std::numbers::pi * std::sqrt(sigma.determinant()));
  return norm * std::exp(-0.5 * mu.dot(sigma.inverse() * mu));
}

TEST(CorrespondenceTest, MatchesTheDensityOfTheDifference) {
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    const Eigen::Matrix4d joint = RandomCovariance(seed);
    const Eigen::Vector2d mj(0.3 * seed, -0.2), mk(0.1, 0.05 * seed);
    Eigen::Matrix<double, 2, 4> d;
    d << Eigen::Matrix2d::Identity(), -Eigen::Matrix2d::Identity();
    const Eigen::Matrix2d sigma = d * joint * d.transpose();
    const CorrespondenceResult result = CorrespondenceTest(mj, mk, joint);
    ASSERT_TRUE(result.valid);
    const double expected = DenseDensityAtZero(mj - mk, sigma);
    EXPECT_NEAR(result.probability, expected, 1e-12 * expected) << "seed " << seed;
    EXPECT_NEAR(result.mahalanobis_squared, (mj - mk).dot(sigma.inverse() * (mj - mk)), 1e-9);
  }
}

TEST(CorrespondenceTest, InformationFormAgreesWithMoments) {
  const Eigen::Matrix4d covariance = RandomCovariance(7);
  const Eigen::Vector4d mean(1.0, 2.0, 1.5, 1.7);
  const Eigen::Matrix4d information = covariance.inverse();
  const CorrespondenceResult a =
      CorrespondenceTestFromInformation(information, information * mean);
  const CorrespondenceResult b = CorrespondenceTest(mean.head<2>(), mean.tail<2>(), covariance);
  ASSERT_TRUE(a.valid && b.valid);
  EXPECT_NEAR(a.probability, b.probability, 1e-10 * b.probability);
}

// The paper's l.4 (Omega_D = D^T Omega D) would give independent features with
// information a and b the information a + b; the right answer is ab/(a+b).
TEST(CorrespondenceTest, IndependentFeaturesAddCovariancesNotInformation) {
  Eigen::Matrix4d joint = Eigen::Matrix4d::Zero();
  joint.topLeftCorner<2, 2>() = 0.25 * Eigen::Matrix2d::Identity();     // a = 4
  joint.bottomRightCorner<2, 2>() = 1.0 * Eigen::Matrix2d::Identity();  // b = 1
  const CorrespondenceResult r =
      CorrespondenceTest(Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d::Zero(), joint);
  ASSERT_TRUE(r.valid);
  EXPECT_NEAR(r.mahalanobis_squared, 1.0 / 1.25, 1e-14);  // Omega_D = 4/5
  EXPECT_NEAR(r.probability, std::exp(-0.4) / (2.0 * std::numbers::pi * 1.25), 1e-14);
}

TEST(CorrespondenceTest, SingularCovarianceIsInvalid) {
  const CorrespondenceResult r = CorrespondenceTest(Eigen::Vector2d(1, 0), Eigen::Vector2d(1, 0),
                                                    Eigen::Matrix4d::Zero());
  EXPECT_FALSE(r.valid);
}

TEST(PoseMarginals, ColumnBlocksEqualTheDenseInverse) {
  const BlockSparseMatrix s = testing::RandomSpdMatrix(3, 3, 40);
  const Eigen::MatrixXd inverse = s.ToDense().inverse();
  PoseMarginals marginals;
  ASSERT_TRUE(marginals.Factorize(s).ok());
  const std::vector<int> blocks = {5, 0, 39, 17, 18};
  int visited = 0;
  ASSERT_TRUE(marginals
                  .ForEachColumnBlock(blocks, 2,
                                      [&](int block, const Eigen::Ref<const Eigen::MatrixXd>& c) {
                                        const Eigen::MatrixXd expected =
                                            inverse.middleCols(3 * block, 3);
                                        EXPECT_LT((c - expected).norm(), 1e-10 * expected.norm())
                                            << "block " << block;
                                        ++visited;
                                      })
                  .ok());
  EXPECT_EQ(visited, 5);
  EXPECT_TRUE(marginals.ForEachColumnBlock({40}, 1, [](int, const auto&) {}).IsInvalidArgument());
}

// y_a^T y_b = B_a^T S^{-1} B_b for sparse block combinations (a feature's
// gains), against the dense inverse; a block may repeat and blocks come in
// any order.
TEST(PoseMarginals, WhitenedDotProductsEqualTheDenseInverse) {
  for (int seed : {1, 2}) {
    const BlockSparseMatrix s = testing::RandomSpdMatrix(seed, 3, 60);
    const Eigen::MatrixXd inverse = s.ToDense().inverse();
    PoseMarginals marginals;
    ASSERT_TRUE(marginals.Factorize(s).ok());
    EXPECT_GE(marginals.MeanReach(), 1.0);
    EXPECT_LE(marginals.MeanReach(), 180.0);
    std::mt19937 rng(seed);
    std::uniform_int_distribution<int> block(0, 59);
    auto random_b = [&](int count, std::vector<int32_t>* blocks,
                        std::vector<Eigen::Matrix<double, 3, 2>>* values) {
      Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(180, 2);
      for (int i = 0; i < count; ++i) {
        blocks->push_back(block(rng));
        values->push_back(Eigen::Matrix<double, 3, 2>::Random());
        dense.middleRows(3 * blocks->back(), 3) += values->back();
      }
      return dense;
    };
    PoseMarginals::WhitenWorkspace workspace;
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<int32_t> blocks_a, blocks_b;
      std::vector<Eigen::Matrix<double, 3, 2>> values_a, values_b;
      const Eigen::MatrixXd a = random_b(1 + trial % 4, &blocks_a, &values_a);
      const Eigen::MatrixXd b = random_b(1 + trial % 3, &blocks_b, &values_b);
      PoseMarginals::WhitenedColumns ya, yb;
      ASSERT_TRUE(marginals.Whiten(blocks_a, values_a, &ya, &workspace).ok());
      ASSERT_TRUE(marginals.Whiten(blocks_b, values_b, &yb, &workspace).ok());
      EXPECT_TRUE(std::is_sorted(ya.rows.begin(), ya.rows.end()));
      const Eigen::Matrix2d expected_ab = a.transpose() * inverse * b;
      const Eigen::Matrix2d expected_aa = a.transpose() * inverse * a;
      EXPECT_LT((PoseMarginals::Dot(ya, yb) - expected_ab).norm(), 1e-9 * expected_aa.norm())
          << "seed " << seed << " trial " << trial;
      EXPECT_LT((PoseMarginals::Dot(ya, ya) - expected_aa).norm(), 1e-9 * expected_aa.norm());
    }
    std::vector<int32_t> outside = {60};
    std::vector<Eigen::Matrix<double, 3, 2>> one(1, Eigen::Matrix<double, 3, 2>::Ones());
    PoseMarginals::WhitenedColumns y;
    EXPECT_TRUE(marginals.Whiten(outside, one, &y, &workspace).IsInvalidArgument());
  }
}

// A pose chain (block tridiagonal): nested dissection keeps the elimination
// tree shallow, so a unit vector's reach is far below the chain length.
TEST(PoseMarginals, ChainReachIsShallow) {
  const int n = 2000;
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i + 1 < n; ++i) pairs.emplace_back(i, i + 1);
  BlockSparseMatrix s = BlockSparseMatrix::FromPattern(3, n, pairs);
  for (int i = 0; i < n; ++i) ASSERT_TRUE(s.AddBlock(i, i, 4.0 * Eigen::Matrix3d::Identity()));
  for (int i = 0; i + 1 < n; ++i)
    ASSERT_TRUE(s.AddBlock(i, i + 1, -1.0 * Eigen::Matrix3d::Identity()));
  PoseMarginals marginals;
  ASSERT_TRUE(marginals.Factorize(s).ok());
  EXPECT_LT(marginals.MeanReach(), 0.05 * 3 * n) << "mean reach " << marginals.MeanReach();
}

}  // namespace
}  // namespace graphslam::core
