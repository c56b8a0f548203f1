// Schur elimination of features, feature by feature, against the dense Schur
// complement and the dense solution of the whole system.
#include "core/schur_eliminator.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace graphslam::core {
namespace {

// A random SPD system over P poses (block size b) and F features (dimension
// d): poses are linked in a chain plus a few loop closures, each feature is
// seen by a random subset of 1..4 poses, features never touch each other.
// Unknown order in the dense matrix: all poses, then all features.
struct RandomSystem {
  int b = 0, d = 0, num_poses = 0, num_features = 0;
  Eigen::MatrixXd h;                   // full information matrix
  Eigen::VectorXd g;                   // full gradient
  std::vector<std::vector<int>> seen;  // poses observing each feature (unique, unordered)
  std::vector<std::pair<int, int>> pose_pairs;

  int PoseRows() const { return b * num_poses; }
  int FeatureOffset(int m) const { return PoseRows() + d * m; }

  FeatureBlocks Feature(int m) const {
    FeatureBlocks f;
    f.feature_information = h.block(FeatureOffset(m), FeatureOffset(m), d, d);
    f.feature_gradient = g.segment(FeatureOffset(m), d);
    f.poses = seen[m];
    for (int p : seen[m]) f.pose_feature.push_back(h.block(b * p, FeatureOffset(m), b, d));
    return f;
  }
};

RandomSystem MakeRandomSystem(uint32_t seed, int b, int d, int num_poses, int num_features) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  std::uniform_int_distribution<int> pose(0, num_poses - 1);
  std::uniform_int_distribution<int> count(1, 4);
  RandomSystem s;
  s.b = b;
  s.d = d;
  s.num_poses = num_poses;
  s.num_features = num_features;
  const int n = b * num_poses + d * num_features;
  s.h = Eigen::MatrixXd::Zero(n, n);
  auto fill = [&](int row, int col, int rows, int cols) {
    for (int r = 0; r < rows; ++r) {
      for (int c = 0; c < cols; ++c) {
        const double v = value(rng);
        s.h(row + r, col + c) += v;
        s.h(col + c, row + r) += v;
      }
    }
  };
  for (int p = 0; p + 1 < num_poses; ++p) s.pose_pairs.emplace_back(p, p + 1);
  for (int e = 0; e < num_poses / 3; ++e) {
    const int p = pose(rng), q = pose(rng);
    if (p != q) s.pose_pairs.emplace_back(std::min(p, q), std::max(p, q));
  }
  std::sort(s.pose_pairs.begin(), s.pose_pairs.end());
  s.pose_pairs.erase(std::unique(s.pose_pairs.begin(), s.pose_pairs.end()), s.pose_pairs.end());
  for (const auto& [p, q] : s.pose_pairs) fill(b * p, b * q, b, b);
  s.seen.resize(num_features);
  for (int m = 0; m < num_features; ++m) {
    std::set<int> poses;
    const int k = std::min(count(rng), num_poses);
    while (static_cast<int>(poses.size()) < k) poses.insert(pose(rng));
    s.seen[m].assign(poses.begin(), poses.end());
    std::shuffle(s.seen[m].begin(), s.seen[m].end(), rng);  // order must not matter
    for (int p : s.seen[m]) fill(b * p, s.FeatureOffset(m), b, d);
  }
  // Diagonal blocks: random SPD plus the absolute row sum, so that H is
  // strictly diagonally dominant and hence SPD (and so is every H_mm).
  for (int i = 0; i < n; ++i) s.h(i, i) = 0.0;
  const Eigen::VectorXd row_sums = s.h.cwiseAbs().rowwise().sum();
  for (int i = 0; i < n; ++i) s.h(i, i) = row_sums[i] + 0.5 + std::abs(value(rng));
  s.g.resize(n);
  for (int i = 0; i < n; ++i) s.g[i] = value(rng);
  return s;
}

// Pattern of the reduced system: pose pairs plus every pair co-observing a feature.
BlockSparseMatrix ReducedPattern(const RandomSystem& s) {
  std::vector<std::pair<int, int>> pairs = s.pose_pairs;
  for (const auto& poses : s.seen) {
    for (int p : poses)
      for (int q : poses) pairs.emplace_back(p, q);
  }
  return BlockSparseMatrix::FromPattern(s.b, s.num_poses, pairs);
}

double RelativeError(const Eigen::MatrixXd& actual, const Eigen::MatrixXd& expected) {
  return (actual - expected).norm() / expected.norm();
}

struct Sizes {
  int b, d;
};

class SchurEliminatorTest : public testing::TestWithParam<Sizes> {};

TEST_P(SchurEliminatorTest, ReducedSystemAndRecoveryMatchDenseSchurComplement) {
  const auto [b, d] = GetParam();
  for (uint32_t seed = 1; seed <= 6; ++seed) {
    SCOPED_TRACE(testing::Message() << "b " << b << ", d " << d << ", seed " << seed);
    const RandomSystem sys = MakeRandomSystem(seed, b, d, 6 + 3 * seed, 10 + 5 * seed);
    const int np = sys.PoseRows();
    const int nf = sys.d * sys.num_features;

    // Reduced system assembled the way the solver does: A and -g_x by the
    // caller, then every feature's contribution.
    BlockSparseMatrix s = ReducedPattern(sys);
    Eigen::VectorXd rhs = -sys.g.head(np);
    for (int i = 0; i < sys.num_poses; ++i) {
      ASSERT_TRUE(s.AddBlock(i, i, sys.h.block(b * i, b * i, b, b)));
    }
    for (const auto& [p, q] : sys.pose_pairs) {
      ASSERT_TRUE(s.AddBlock(p, q, sys.h.block(b * p, b * q, b, b)));
    }
    ReducedContribution contribution;
    std::vector<FeatureBlocks> features;
    for (int m = 0; m < sys.num_features; ++m) {
      features.push_back(sys.Feature(m));
      contribution.Clear();  // reused: keeps its capacity
      ASSERT_TRUE(EliminateFeature(features.back(), &contribution).ok());
      const size_t k = features.back().poses.size();
      EXPECT_EQ(contribution.num_blocks(), k * (k + 1) / 2);
      EXPECT_EQ(contribution.num_rhs_rows(), k);
      AccumulateContribution(contribution, &s, &rhs);
    }

    // Dense reference: S = H_xx - H_xm H_mm^{-1} H_mx, rhs = -g_x + H_xm H_mm^{-1} g_m.
    const Eigen::MatrixXd h_xx = sys.h.topLeftCorner(np, np);
    const Eigen::MatrixXd h_xm = sys.h.topRightCorner(np, nf);
    const Eigen::MatrixXd h_mm = sys.h.bottomRightCorner(nf, nf);
    const Eigen::LDLT<Eigen::MatrixXd> h_mm_ldlt(h_mm);
    const Eigen::MatrixXd expected_s = h_xx - h_xm * h_mm_ldlt.solve(h_xm.transpose());
    const Eigen::VectorXd expected_rhs =
        -sys.g.head(np) + h_xm * h_mm_ldlt.solve(sys.g.tail(nf));
    const Eigen::MatrixXd actual_s = s.ToDense();
    // Relative 1e-12: well-conditioned (diagonally dominant) blocks.
    EXPECT_LE(RelativeError(actual_s, expected_s), 1e-12)
        << "reduced:\n" << actual_s << "\ndense Schur complement:\n" << expected_s;
    EXPECT_LE(RelativeError(rhs, expected_rhs), 1e-12)
        << "reduced rhs: " << rhs.transpose() << "\ndense rhs:   " << expected_rhs.transpose();

    // Solve the reduced system densely, recover the features, compare with
    // the dense solution of the whole system H [dx; dm] = -g.
    const Eigen::VectorXd dx = actual_s.ldlt().solve(rhs);
    Eigen::VectorXd actual(np + nf);
    actual.head(np) = dx;
    for (int m = 0; m < sys.num_features; ++m) {
      actual.segment(np + d * m, d) = RecoverFeature(features[m], dx);
    }
    const Eigen::VectorXd expected = sys.h.ldlt().solve(-sys.g);
    EXPECT_LE(RelativeError(actual, expected), 1e-10)
        << "Schur + recovery: " << actual.transpose() << "\ndense solve:      "
        << expected.transpose();
  }
}

INSTANTIATE_TEST_SUITE_P(PoseAndFeatureSizes, SchurEliminatorTest,
                         testing::Values(Sizes{3, 2}, Sizes{6, 3}, Sizes{3, 3}, Sizes{6, 2},
                                         Sizes{1, 2}),
                         [](const testing::TestParamInfo<Sizes>& info) {
                           std::string name = "b";
                           name += std::to_string(info.param.b);
                           name += "d";
                           name += std::to_string(info.param.d);
                           return name;
                         });

TEST(SchurEliminator, SeveralFeaturesAppendToOneContribution) {
  const RandomSystem sys = MakeRandomSystem(11, 3, 2, 8, 12);
  ReducedContribution all;
  ReducedContribution one;
  BlockSparseMatrix s_all = ReducedPattern(sys);
  BlockSparseMatrix s_one = ReducedPattern(sys);
  Eigen::VectorXd rhs_all = Eigen::VectorXd::Zero(s_all.num_rows());
  Eigen::VectorXd rhs_one = rhs_all;
  for (int m = 0; m < sys.num_features; ++m) {
    ASSERT_TRUE(EliminateFeature(sys.Feature(m), &all).ok());
    one.Clear();
    ASSERT_TRUE(EliminateFeature(sys.Feature(m), &one).ok());
    AccumulateContribution(one, &s_one, &rhs_one);
  }
  AccumulateContribution(all, &s_all, &rhs_all);
  // Onto a zero S the sums start where the one-by-one additions do and add
  // the same terms in the same order: bit-exact.
  EXPECT_EQ(s_all.ToDense(), s_one.ToDense());
  EXPECT_EQ(rhs_all, rhs_one);
}

// Many features summed per position in one contribution, then added to an
// S that is not zero, equal feature-by-feature accumulation up to rounding;
// every position is stored once, in the upper triangle.
TEST(SchurEliminator, SummedPositionsMatchFeatureByFeatureOnNonZeroS) {
  for (const Sizes sizes : {Sizes{3, 2}, Sizes{6, 3}}) {
    SCOPED_TRACE(testing::Message() << "b " << sizes.b << ", d " << sizes.d);
    const RandomSystem sys = MakeRandomSystem(12, sizes.b, sizes.d, 8, 40);
    ReducedContribution all;
    ReducedContribution one;
    BlockSparseMatrix s_all = ReducedPattern(sys);
    BlockSparseMatrix s_one = ReducedPattern(sys);
    for (int i = 0; i < sys.num_poses; ++i) {
      ASSERT_TRUE(s_all.AddBlock(i, i, sys.h.block(sizes.b * i, sizes.b * i, sizes.b, sizes.b)));
      ASSERT_TRUE(s_one.AddBlock(i, i, sys.h.block(sizes.b * i, sizes.b * i, sizes.b, sizes.b)));
    }
    Eigen::VectorXd rhs_all = -sys.g.head(sys.PoseRows());
    Eigen::VectorXd rhs_one = rhs_all;
    size_t entries = 0;
    for (int m = 0; m < sys.num_features; ++m) {
      ASSERT_TRUE(EliminateFeature(sys.Feature(m), &all).ok());
      one.Clear();
      ASSERT_TRUE(EliminateFeature(sys.Feature(m), &one).ok());
      entries += one.num_blocks();
      AccumulateContribution(one, &s_one, &rhs_one);
    }
    std::set<std::pair<int, int>> positions;
    for (size_t j = 0; j < all.num_blocks(); ++j) {
      EXPECT_LE(all.position(j).first, all.position(j).second);
      EXPECT_TRUE(positions.insert(all.position(j)).second) << "position stored twice";
    }
    EXPECT_LT(all.num_blocks(), entries);  // features share pose pairs
    AccumulateContribution(all, &s_all, &rhs_all);
    // Relative 1e-14: the same terms, summed in another order.
    const Eigen::MatrixXd expected = s_one.ToDense();
    EXPECT_LE(RelativeError(s_all.ToDense(), expected), 1e-14)
        << "summed:\n" << s_all.ToDense() << "\nfeature by feature:\n" << expected;
    EXPECT_LE(RelativeError(rhs_all, rhs_one), 1e-14)
        << "summed: " << rhs_all.transpose() << "\nfeature by feature: " << rhs_one.transpose();
  }
}

TEST(SchurEliminator, NonPositiveDefiniteFeatureIsReportedAndLeavesOutputUnchanged) {
  FeatureBlocks f;
  f.feature_gradient = Eigen::Vector2d(1.0, 2.0);
  f.poses = {0, 1};
  f.pose_feature = {Eigen::MatrixXd::Ones(3, 2), Eigen::MatrixXd::Ones(3, 2)};
  ReducedContribution out;

  // A feature seen once by bearing only: rank 1.
  const Eigen::Vector2d direction(0.6, 0.8);
  f.feature_information = direction * direction.transpose();
  Status status = EliminateFeature(f, &out);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();
  EXPECT_NE(status.message().find("feature information is not positive definite"),
            std::string::npos)
      << status.ToString();
  EXPECT_NE(status.message().find("min eigenvalue"), std::string::npos) << status.ToString();

  f.feature_information = Eigen::Vector2d(1.0, -1.0).asDiagonal();  // indefinite
  status = EliminateFeature(f, &out);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();

  f.feature_information = Eigen::Vector2d(1.0, 1e-14).asDiagonal();  // below 1e-12 relative
  status = EliminateFeature(f, &out);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();

  f.feature_information = Eigen::Matrix2d::Identity() * std::nan("");
  status = EliminateFeature(f, &out);
  EXPECT_TRUE(status.IsNumerical()) << status.ToString();

  EXPECT_EQ(out.block_size(), 0);
  EXPECT_EQ(out.num_blocks(), 0u);
  EXPECT_EQ(out.num_rhs_rows(), 0u);

  f.feature_information = Eigen::Vector2d(1.0, 1e-9).asDiagonal();  // weak but accepted
  EXPECT_TRUE(EliminateFeature(f, &out).ok());
  EXPECT_EQ(out.block_size(), 3);
}

// Planar features take a scalar path (2 x 2 Cholesky, the products per
// pose written out): with the planar pose block (b = 3) it gives the numbers
// of Eigen's LLT on the generic expression to the bit; other b only to
// rounding (Eigen's product sums a longer row in another order).
TEST(SchurEliminator, PlanarRecoveryEqualsEigensLltBitForBit) {
  for (const int b : {1, 3, 6}) {
    for (uint32_t seed = 1; seed <= 4; ++seed) {
      SCOPED_TRACE(testing::Message() << "b " << b << ", seed " << seed);
      const RandomSystem sys = MakeRandomSystem(20 + seed, b, 2, 7, 25);
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> value(-3.0, 3.0);
      Eigen::VectorXd dx(sys.PoseRows());
      for (Eigen::Index i = 0; i < dx.size(); ++i) dx[i] = value(rng);
      for (int m = 0; m < sys.num_features; ++m) {
        const FeatureBlocks f = sys.Feature(m);
        Eigen::Vector2d v = f.feature_gradient;
        for (size_t p = 0; p < f.poses.size(); ++p)
          v.noalias() += f.pose_feature[p].transpose() * dx.segment(f.poses[p] * b, b);
        const Eigen::Vector2d expected =
            -Eigen::LLT<Eigen::Matrix2d>(Eigen::Matrix2d(f.feature_information)).solve(v);
        const Eigen::VectorXd actual = RecoverFeature(f, dx);
        ASSERT_EQ(actual.size(), 2);
        if (b == 3) {
          EXPECT_EQ(actual[0], expected[0]) << "feature " << m;
          EXPECT_EQ(actual[1], expected[1]) << "feature " << m;
        } else {
          EXPECT_LE((actual - expected).norm(), 1e-14 * expected.norm()) << "feature " << m;
        }
      }
    }
  }
}

TEST(SchurEliminator, FeatureWithoutFreePosesContributesNothing) {
  FeatureBlocks f;
  f.feature_information = Eigen::Matrix2d::Identity() * 2.0;
  f.feature_gradient = Eigen::Vector2d(1.0, -4.0);
  ReducedContribution out;
  ASSERT_TRUE(EliminateFeature(f, &out).ok());
  EXPECT_EQ(out.num_blocks(), 0u);
  EXPECT_EQ(out.num_rhs_rows(), 0u);
  const Eigen::VectorXd dm = RecoverFeature(f, Eigen::VectorXd());
  const Eigen::Vector2d expected(-0.5, 2.0);
  EXPECT_LE((dm - expected).norm(), 1e-15 * expected.norm())
      << "recovered: " << dm.transpose() << "\nexpected:  " << expected.transpose();
}

}  // namespace
}  // namespace graphslam::core
