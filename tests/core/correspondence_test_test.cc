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

}  // namespace
}  // namespace graphslam::core
