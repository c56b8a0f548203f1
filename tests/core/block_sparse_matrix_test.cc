// Property tests of BlockSparseMatrix against dense Eigen reference math on
// random seeded patterns.
#include "core/block_sparse_matrix.h"

#include <gtest/gtest.h>
#include <tbb/parallel_invoke.h>
#include <tbb/task_arena.h>

#include <random>
#include <utility>
#include <vector>

#include "tests/testing/random_linear_system.h"

namespace graphslam::core {
namespace {

// Random pattern: a chain (i, i+1) plus `extra` random pairs, some repeated
// and some given as (k, i) and (i, i), to exercise deduplication.
std::vector<std::pair<int, int>> RandomPairs(std::mt19937* rng, int n, int extra) {
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i + 1 < n; ++i) pairs.emplace_back(i + 1, i);
  std::uniform_int_distribution<int> index(0, n - 1);
  for (int e = 0; e < extra; ++e) {
    const int i = index(*rng), k = index(*rng);
    pairs.emplace_back(i, k);
    if (e % 5 == 0) pairs.emplace_back(k, i);  // duplicate in transposed form
  }
  return pairs;
}

// Fills every pattern pair with random values, symmetric by construction.
void FillRandom(std::mt19937* rng, const std::vector<std::pair<int, int>>& pairs,
                BlockSparseMatrix* m) {
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  const int b = m->block_size();
  auto random_block = [&] {
    Eigen::MatrixXd block(b, b);
    for (int r = 0; r < b; ++r)
      for (int c = 0; c < b; ++c) block(r, c) = value(*rng);
    return block;
  };
  for (const auto& [i, k] : pairs) {
    Eigen::MatrixXd block = random_block();
    if (i == k) block = (block + block.transpose()).eval();
    ASSERT_TRUE(m->AddBlock(i, k, block));
  }
  for (int i = 0; i < m->num_block_rows(); ++i) {
    Eigen::MatrixXd block = random_block();
    ASSERT_TRUE(m->AddBlock(i, i, block * block.transpose()));
  }
}

Eigen::VectorXd RandomVector(std::mt19937* rng, int n) {
  std::uniform_real_distribution<double> value(-1.0, 1.0);
  Eigen::VectorXd v(n);
  for (int j = 0; j < n; ++j) v[j] = value(*rng);
  return v;
}

TEST(BlockSparseMatrix, PatternStoresTheUpperTriangleOnceAndEveryDiagonal) {
  BlockSparseMatrix m =
      BlockSparseMatrix::FromPattern(3, 5, {{0, 2}, {2, 0}, {0, 2}, {4, 1}, {3, 3}});
  EXPECT_EQ(m.block_size(), 3);
  EXPECT_EQ(m.num_block_rows(), 5);
  EXPECT_EQ(m.num_rows(), 15);
  EXPECT_EQ(m.num_stored_blocks(), 5 + 2);   // 5 diagonal + (0,2), (1,4)
  EXPECT_EQ(m.num_nonzero_blocks(), 5 + 4);  // and their transposes
  for (int i = 0; i < 5; ++i) EXPECT_NE(m.Block(i, i), nullptr) << "diagonal block " << i;
  EXPECT_NE(m.Block(0, 2), nullptr);
  EXPECT_NE(m.Block(1, 4), nullptr);
  // The lower triangle is not stored: no pointer, but HasBlock sees it.
  EXPECT_EQ(m.Block(2, 0), nullptr);
  EXPECT_EQ(m.Block(4, 1), nullptr);
  EXPECT_TRUE(m.HasBlock(2, 0));
  EXPECT_TRUE(m.HasBlock(4, 1));
  EXPECT_TRUE(m.HasBlock(1, 4));
  EXPECT_FALSE(m.HasBlock(1, 0));
  EXPECT_EQ(m.Block(0, 1), nullptr);
  EXPECT_EQ(m.Block(3, 4), nullptr);
  EXPECT_EQ(m.Block(-1, 0), nullptr);
  EXPECT_EQ(m.Block(0, 5), nullptr);
  EXPECT_FALSE(m.HasBlock(0, 5));
  // Rows hold k >= i, ascending, the diagonal first.
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(m.block_cols()[m.row_start()[i]], i);
    for (int64_t j = m.row_start()[i] + 1; j < m.row_start()[i + 1]; ++j) {
      EXPECT_LT(m.block_cols()[j - 1], m.block_cols()[j]);
    }
  }
  // The transpose index: column 2 holds (0,2), column 4 holds (1,4).
  EXPECT_EQ(m.col_start(), (std::vector<int64_t>{0, 0, 0, 1, 1, 2}));
  EXPECT_EQ(m.col_rows(), (std::vector<int>{0, 1}));
  EXPECT_EQ(m.StoredBlock(m.col_blocks()[0]), m.Block(0, 2));
  EXPECT_EQ(m.StoredBlock(m.col_blocks()[1]), m.Block(1, 4));
}

TEST(BlockSparseMatrix, AddBlockOfALowerPairLandsTransposedAndOutsideThePatternIsRejected) {
  BlockSparseMatrix m = BlockSparseMatrix::FromPattern(2, 3, {{0, 2}});
  Eigen::MatrixXd block(2, 2);
  block << 1, 2, 3, 4;
  EXPECT_TRUE(m.AddBlock(0, 2, block));
  EXPECT_TRUE(m.AddBlock(2, 0, block.transpose()));  // the same entries, given as A_20
  EXPECT_FALSE(m.AddBlock(0, 1, block));
  EXPECT_FALSE(m.AddBlock(1, 0, block));
  Eigen::MatrixXd expected = Eigen::MatrixXd::Zero(6, 6);
  expected.block(0, 4, 2, 2) = 2 * block;
  expected.block(4, 0, 2, 2) = 2 * block.transpose();
  EXPECT_EQ(m.ToDense(), expected) << "sparse:\n" << m.ToDense() << "\ndense:\n" << expected;
  // Row-major raw storage of the stored block (0,2) = 2 block.
  const double* raw = m.Block(0, 2);
  EXPECT_EQ(raw[0], 2.0);
  EXPECT_EQ(raw[1], 4.0);
  EXPECT_EQ(raw[2], 6.0);
  EXPECT_EQ(raw[3], 8.0);
  // A lower block alone: A_20 = lower, so U_02 = lower^T.
  Eigen::MatrixXd lower(2, 2);
  lower << 10, 20, 30, 40;
  m.SetZero();
  EXPECT_TRUE(m.AddBlock(2, 0, lower));
  EXPECT_EQ(raw[0], 10.0);
  EXPECT_EQ(raw[1], 30.0);
  EXPECT_EQ(raw[2], 20.0);
  EXPECT_EQ(raw[3], 40.0);
  EXPECT_EQ(Eigen::MatrixXd(m.ToDense().block(4, 0, 2, 2)), lower);

  Eigen::MatrixXd diagonal(2, 2);
  diagonal << 5, 1, 1, 7;
  EXPECT_TRUE(m.AddBlock(1, 1, diagonal));  // added once, not twice
  EXPECT_EQ(m.ToDense().block(2, 2, 2, 2), diagonal);
}

// The former full-storage product, verbatim: every block row of the dense
// matrix, blocks in ascending column order, row-major A_ik times x_k. The
// one-sweep product adds the same terms in another order.
template <int kB>
Eigen::VectorXd FullStorageProduct(const BlockSparseMatrix& m, const Eigen::VectorXd& x,
                                   Eigen::VectorXd y) {
  using BlockMatrix = Eigen::Matrix<double, kB, kB, Eigen::RowMajor>;
  using ConstVectorMap = Eigen::Map<const Eigen::Matrix<double, kB, 1>>;
  const Eigen::MatrixXd dense = m.ToDense();
  for (int i = 0; i < m.num_block_rows(); ++i) {
    std::vector<int> columns;
    for (int64_t t = m.col_start()[i]; t < m.col_start()[i + 1]; ++t) {
      columns.push_back(m.col_rows()[t]);
    }
    for (int64_t j = m.row_start()[i]; j < m.row_start()[i + 1]; ++j) {
      columns.push_back(m.block_cols()[j]);
    }
    Eigen::Matrix<double, kB, 1> sum = Eigen::Matrix<double, kB, 1>::Zero();
    for (int k : columns) {
      const BlockMatrix a = dense.block(i * kB, k * kB, kB, kB);
      const std::vector<double> row_major(a.data(), a.data() + kB * kB);
      sum.noalias() += Eigen::Map<const BlockMatrix>(row_major.data()) *
                       ConstVectorMap(x.data() + static_cast<int64_t>(k) * kB);
    }
    y.segment<kB>(i * kB) += sum;
  }
  return y;
}

// A banded pose-system pattern (each pose coupled to its `band` successors)
// plus 2 random loop closures per pose, split into product ranges of
// `blocks_per_range` stored blocks: the accumulators take the band and some
// closures; a range reaching more than 4x its own rows leaves the rest far.
BlockSparseMatrix BandedWithLoopClosures(uint32_t seed, int b, int n, int band,
                                         int64_t blocks_per_range) {
  std::mt19937 rng(seed);
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i) {
    for (int o = 1; o <= band && i + o < n; ++o) pairs.emplace_back(i, i + o);
  }
  std::uniform_int_distribution<int> index(0, n - 1);
  for (int e = 0; e < 2 * n; ++e) pairs.emplace_back(index(rng), index(rng));
  BlockSparseMatrix m = BlockSparseMatrix::FromPattern(b, n, pairs);
  FillRandom(&rng, pairs, &m);
  m.PartitionForProduct(blocks_per_range);
  return m;
}

TEST(BlockSparseMatrix, SymmetricProductEqualsDenseAndFullStorageOnRandomSpdSystems) {
  // The default split (one range below ~14000 stored blocks of size 3) and
  // many small ranges, whose accumulators and far blocks take the merge path.
  for (int b : {3, 6}) {
    for (int n : {40, BlockSparseMatrix::kMinBlockRowsForParallel + 44}) {
      for (int64_t blocks_per_range : {int64_t{0}, int64_t{9}, int64_t{50}}) {
        SCOPED_TRACE(::testing::Message() << "block size " << b << ", " << n << " block rows, "
                                          << blocks_per_range << " blocks per range");
        BlockSparseMatrix m = graphslam::testing::RandomSpdMatrix(900 + b + n, b, n);
        if (blocks_per_range > 0) {
          m.PartitionForProduct(blocks_per_range);
          EXPECT_GT(m.num_product_ranges(), 2);
          EXPECT_GT(m.num_far_blocks() + m.num_accumulator_rows(), 0);  // the merge has work
        } else {
          EXPECT_EQ(m.num_product_ranges(), 1);
        }
        const Eigen::VectorXd x = graphslam::testing::RandomVector(31 + n, m.num_rows());
        const Eigen::VectorXd y0 = graphslam::testing::RandomVector(37 + n, m.num_rows());
        Eigen::VectorXd y = y0;
        m.RightMultiplyAndAccumulate(x.data(), y.data());
        const Eigen::VectorXd expected = y0 + m.ToDense() * x;
        EXPECT_LE((y - expected).norm(), 1e-14 * expected.norm());
        // Full storage: the same sums in another order.
        const Eigen::VectorXd full =
            b == 3 ? FullStorageProduct<3>(m, x, y0) : FullStorageProduct<6>(m, x, y0);
        EXPECT_LE((y - full).norm(), 1e-14 * full.norm());
      }
    }
  }
  // A band with loop closures: accumulators in use as well as far blocks.
  for (int b : {3, 6, 2}) {
    SCOPED_TRACE(::testing::Message() << "banded, block size " << b);
    const BlockSparseMatrix m = BandedWithLoopClosures(3 + b, b, 500, 6, 40);
    EXPECT_GT(m.num_accumulator_rows(), 0);
    EXPECT_GT(m.num_far_blocks(), 0);
    EXPECT_LE(m.num_accumulator_rows(), 4 * m.num_block_rows());  // the memory bound
    const Eigen::VectorXd x = graphslam::testing::RandomVector(8, m.num_rows());
    const Eigen::VectorXd y0 = graphslam::testing::RandomVector(9, m.num_rows());
    Eigen::VectorXd y = y0;
    m.RightMultiplyAndAccumulate(x.data(), y.data());
    const Eigen::VectorXd expected = y0 + m.ToDense() * x;
    EXPECT_LE((y - expected).norm(), 1e-14 * expected.norm());
  }
}

TEST(BlockSparseMatrix, ProductIsIndependentOfTheThreadCountBitForBit) {
  // The ranges are a function of the matrix: 1, 2, 3, 4, 8 threads and
  // repeated runs give the same bits, equal to the serial product.
  for (int b : {3, 6, 4}) {
    for (int64_t blocks_per_range : {int64_t{0}, int64_t{13}, int64_t{200}}) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", " << blocks_per_range
                                        << " blocks per range");
      BlockSparseMatrix m = BandedWithLoopClosures(77 + b, b, 1200, 8, 100);
      if (blocks_per_range > 0) {
        m.PartitionForProduct(blocks_per_range);
        ASSERT_GT(m.num_product_ranges(), 3);
      }
      const Eigen::VectorXd x = graphslam::testing::RandomVector(5, m.num_rows());
      const Eigen::VectorXd y0 = graphslam::testing::RandomVector(6, m.num_rows());
      Eigen::VectorXd serial = y0;
      m.RightMultiplyAndAccumulateSerial(x.data(), serial.data());
      for (int threads : {1, 2, 4, 3, 8, 2}) {
        tbb::task_arena arena(threads);
        Eigen::VectorXd y = y0;
        arena.execute([&] { m.RightMultiplyAndAccumulate(x.data(), y.data()); });
        EXPECT_EQ((y - serial).cwiseAbs().maxCoeff(), 0.0) << threads << " threads";
      }
      // A copy (own accumulators) and a concurrent caller (private ones).
      const BlockSparseMatrix copy = m;
      Eigen::VectorXd y_copy = y0, y_a = y0, y_b = y0;
      copy.RightMultiplyAndAccumulate(x.data(), y_copy.data());
      EXPECT_EQ((y_copy - serial).cwiseAbs().maxCoeff(), 0.0);
      tbb::task_arena arena(2);
      arena.execute([&] {
        tbb::parallel_invoke([&] { m.RightMultiplyAndAccumulate(x.data(), y_a.data()); },
                             [&] { m.RightMultiplyAndAccumulate(x.data(), y_b.data()); });
      });
      EXPECT_EQ((y_a - serial).cwiseAbs().maxCoeff(), 0.0);
      EXPECT_EQ((y_b - serial).cwiseAbs().maxCoeff(), 0.0);
    }
  }
}

TEST(BlockSparseMatrix, ProductMatchesDenseForEveryBlockSize) {
  // 3 and 6 take the fixed-size kernels, 1, 2 and 4 the dynamic one.
  for (int b : {1, 2, 3, 4, 6}) {
    for (uint32_t seed = 1; seed <= 5; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      std::mt19937 rng(seed);
      const int n = 5 + 7 * static_cast<int>(seed);
      const auto pairs = RandomPairs(&rng, n, 2 * n);
      BlockSparseMatrix m = BlockSparseMatrix::FromPattern(b, n, pairs);
      FillRandom(&rng, pairs, &m);
      const Eigen::MatrixXd dense = m.ToDense();
      ASSERT_EQ(dense, dense.transpose());  // one stored triangle: exactly symmetric
      const Eigen::VectorXd x = RandomVector(&rng, m.num_rows());
      const Eigen::VectorXd y0 = RandomVector(&rng, m.num_rows());
      Eigen::VectorXd y = y0;
      m.RightMultiplyAndAccumulate(x.data(), y.data());
      const Eigen::VectorXd expected = y0 + dense * x;
      // Relative tolerance 1e-14: only the summation order differs.
      EXPECT_LE((y - expected).norm(), 1e-14 * expected.norm())
          << "sparse: " << y.transpose() << "\ndense:  " << expected.transpose();
    }
  }
}

TEST(BlockSparseMatrix, ParallelProductEqualsSerialBitForBit) {
  for (int b : {3, 6, 4}) {
    SCOPED_TRACE(::testing::Message() << "block size " << b);
    std::mt19937 rng(42 + b);
    const int n = 8 * BlockSparseMatrix::kMinBlockRowsForParallel;  // takes the parallel path
    const auto pairs = RandomPairs(&rng, n, 4 * n);
    BlockSparseMatrix m = BlockSparseMatrix::FromPattern(b, n, pairs);
    FillRandom(&rng, pairs, &m);
    const Eigen::VectorXd x = RandomVector(&rng, m.num_rows());
    const Eigen::VectorXd y0 = RandomVector(&rng, m.num_rows());
    Eigen::VectorXd y_s = y0;
    Eigen::VectorXd y_p = y0;
    m.RightMultiplyAndAccumulateSerial(x.data(), y_s.data());
    m.RightMultiplyAndAccumulate(x.data(), y_p.data());
    EXPECT_EQ((y_s - y_p).norm(), 0.);
    // And it is the right product (relative 1e-13).
    const Eigen::VectorXd expected = y0 + m.ToSparseUpper().selfadjointView<Eigen::Upper>() * x;
    EXPECT_LE((y_p - expected).norm(), 1e-13 * expected.norm());
  }
}

TEST(BlockSparseMatrix, ToSparseUpperIsTheUpperTriangleOfTheDenseMatrix) {
  for (int b : {1, 3, 6}) {
    for (uint32_t seed = 1; seed <= 3; ++seed) {
      SCOPED_TRACE(::testing::Message() << "block size " << b << ", seed " << seed);
      std::mt19937 rng(100 + seed);
      const int n = 10 * static_cast<int>(seed);
      const auto pairs = RandomPairs(&rng, n, 3 * n);
      BlockSparseMatrix m = BlockSparseMatrix::FromPattern(b, n, pairs);
      FillRandom(&rng, pairs, &m);
      const Eigen::SparseMatrix<double> upper = m.ToSparseUpper();
      ASSERT_TRUE(upper.isCompressed());
      // Row indices sorted within each column, all in the upper triangle.
      for (int c = 0; c < upper.outerSize(); ++c) {
        for (int j = upper.outerIndexPtr()[c]; j < upper.outerIndexPtr()[c + 1]; ++j) {
          EXPECT_LE(upper.innerIndexPtr()[j], c);
          if (j > upper.outerIndexPtr()[c]) {
            EXPECT_LT(upper.innerIndexPtr()[j - 1], upper.innerIndexPtr()[j]);
          }
        }
      }
      const Eigen::MatrixXd dense = m.ToDense();
      const Eigen::MatrixXd expected = dense.triangularView<Eigen::Upper>();
      EXPECT_EQ(Eigen::MatrixXd(upper), expected);  // copies only: exact
    }
  }
}

TEST(BlockSparseMatrix, DiagonalAddToDiagonalAndSetZero) {
  std::mt19937 rng(7);
  const auto pairs = RandomPairs(&rng, 9, 12);
  BlockSparseMatrix m = BlockSparseMatrix::FromPattern(3, 9, pairs);
  FillRandom(&rng, pairs, &m);
  const Eigen::MatrixXd before = m.ToDense();
  EXPECT_EQ(m.Diagonal(), before.diagonal());
  const Eigen::VectorXd d = RandomVector(&rng, m.num_rows());
  m.AddToDiagonal(d);
  Eigen::MatrixXd expected = before;
  expected.diagonal() += d;
  EXPECT_EQ(m.ToDense(), expected);
  const int64_t blocks = m.num_stored_blocks();
  m.SetZero();
  EXPECT_EQ(m.ToDense(), Eigen::MatrixXd::Zero(27, 27));
  EXPECT_EQ(m.num_stored_blocks(), blocks);
}

TEST(BlockSparseMatrix, EmptyMatrix) {
  BlockSparseMatrix m = BlockSparseMatrix::FromPattern(3, 0, {});
  EXPECT_EQ(m.num_rows(), 0);
  EXPECT_EQ(m.num_nonzero_blocks(), 0);
  EXPECT_EQ(m.ToSparseUpper().nonZeros(), 0);
  m.RightMultiplyAndAccumulate(nullptr, nullptr);
}

}  // namespace
}  // namespace graphslam::core
