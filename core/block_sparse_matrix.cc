#include "core/block_sparse_matrix.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

#include "core/check.h"

namespace graphslam::core {
namespace {

// y_i += sum_{k<i} U_ki^T x_k + sum_{k>=i} U_ik x_k for block rows
// [begin, end), with the block size known at compile time. The accumulation
// order per row is fixed (ascending k), which is what makes the parallel
// product bit-exact. The lower blocks are transposed into a row-major
// temporary so that the product expression, and hence Eigen's operation
// order, is the one the former full storage used for A_ik.
template <int kB>
void MultiplyRowsFixed(const int64_t* row_start, const int* block_cols, const int64_t* col_start,
                       const int* col_rows, const int* col_blocks, const double* values,
                       int begin, int end, const double* x, double* y) {
  using Block = Eigen::Matrix<double, kB, kB, Eigen::RowMajor>;
  using BlockMap = Eigen::Map<const Block>;
  using ConstVectorMap = Eigen::Map<const Eigen::Matrix<double, kB, 1>>;
  using VectorMap = Eigen::Map<Eigen::Matrix<double, kB, 1>>;
  for (int i = begin; i < end; ++i) {
    Eigen::Matrix<double, kB, 1> sum = Eigen::Matrix<double, kB, 1>::Zero();
    for (int64_t t = col_start[i]; t < col_start[i + 1]; ++t) {
      const Block lower = BlockMap(values + static_cast<int64_t>(col_blocks[t]) * kB * kB)
                              .transpose();
      sum.noalias() += lower * ConstVectorMap(x + static_cast<int64_t>(col_rows[t]) * kB);
    }
    for (int64_t j = row_start[i]; j < row_start[i + 1]; ++j) {
      sum.noalias() +=
          BlockMap(values + j * kB * kB) * ConstVectorMap(x + static_cast<int64_t>(block_cols[j]) * kB);
    }
    VectorMap(y + static_cast<int64_t>(i) * kB) += sum;
  }
}

// The same for any block size, with plain loops (no Eigen temporaries).
void MultiplyRowsDynamic(int b, const int64_t* row_start, const int* block_cols,
                         const int64_t* col_start, const int* col_rows, const int* col_blocks,
                         const double* values, int begin, int end, const double* x, double* y) {
  const int64_t bb = static_cast<int64_t>(b) * b;
  for (int i = begin; i < end; ++i) {
    double* yi = y + static_cast<int64_t>(i) * b;
    for (int r = 0; r < b; ++r) {
      double sum = 0.0;
      for (int64_t t = col_start[i]; t < col_start[i + 1]; ++t) {
        const double* a = values + col_blocks[t] * bb + r;  // column r of U_ki
        const double* xk = x + static_cast<int64_t>(col_rows[t]) * b;
        for (int c = 0; c < b; ++c) sum += a[static_cast<int64_t>(c) * b] * xk[c];
      }
      for (int64_t j = row_start[i]; j < row_start[i + 1]; ++j) {
        const double* a = values + j * bb + static_cast<int64_t>(r) * b;
        const double* xk = x + static_cast<int64_t>(block_cols[j]) * b;
        for (int c = 0; c < b; ++c) sum += a[c] * xk[c];
      }
      yi[r] += sum;
    }
  }
}

}  // namespace

BlockSparseMatrix BlockSparseMatrix::FromPattern(int block_size, int num_block_rows,
                                                 std::vector<std::pair<int, int>> pairs) {
  GS_CHECK(block_size >= 1);
  GS_CHECK(num_block_rows >= 0);
  GS_CHECK(static_cast<int64_t>(num_block_rows) * block_size <=
           std::numeric_limits<int>::max());
  BlockSparseMatrix m;
  m.block_size_ = block_size;
  m.num_block_rows_ = num_block_rows;

  // Bucket the column indices max(i,k) by row min(i,k) (counting sort), then
  // sort and deduplicate each row. The diagonal goes first in every row.
  std::vector<int64_t> start(num_block_rows + 1, 0);
  for (const auto& [i, k] : pairs) {
    GS_CHECK(i >= 0 && i < num_block_rows && k >= 0 && k < num_block_rows);
    ++start[std::min(i, k) + 1];
  }
  for (int i = 0; i < num_block_rows; ++i) ++start[i + 1];  // the diagonal block
  for (int i = 0; i < num_block_rows; ++i) start[i + 1] += start[i];
  std::vector<int> columns(start[num_block_rows]);
  std::vector<int64_t> fill(start.begin(), start.end() - 1);
  for (int i = 0; i < num_block_rows; ++i) columns[fill[i]++] = i;
  for (const auto& [i, k] : pairs) columns[fill[std::min(i, k)]++] = std::max(i, k);
  pairs.clear();
  pairs.shrink_to_fit();
  fill.clear();
  fill.shrink_to_fit();

  m.row_start_.assign(num_block_rows + 1, 0);
  m.col_start_.assign(num_block_rows + 1, 0);
  int64_t out = 0;
  for (int i = 0; i < num_block_rows; ++i) {
    auto first = columns.begin() + start[i];
    auto last = columns.begin() + start[i + 1];
    std::sort(first, last);
    last = std::unique(first, last);
    GS_CHECK(*first == i);  // every other entry of row i is > i
    for (auto it = first; it != last; ++it) {
      if (*it != i) ++m.col_start_[*it + 1];
      columns[out++] = *it;  // out <= it: compaction in place is safe
    }
    m.row_start_[i + 1] = out;
  }
  GS_CHECK(out <= std::numeric_limits<int>::max());
  columns.resize(out);
  columns.shrink_to_fit();
  m.block_cols_ = std::move(columns);

  // The transpose index: walking the rows in order leaves each column's rows
  // ascending.
  for (int i = 0; i < num_block_rows; ++i) m.col_start_[i + 1] += m.col_start_[i];
  const int64_t strictly_upper = m.col_start_[num_block_rows];
  m.col_rows_.resize(strictly_upper);
  m.col_blocks_.resize(strictly_upper);
  start.assign(m.col_start_.begin(), m.col_start_.end() - 1);
  for (int i = 0; i < num_block_rows; ++i) {
    for (int64_t j = m.row_start_[i] + 1; j < m.row_start_[i + 1]; ++j) {
      const int64_t t = start[m.block_cols_[j]]++;
      m.col_rows_[t] = i;
      m.col_blocks_[t] = static_cast<int>(j);
    }
  }
  m.values_.assign(static_cast<size_t>(out) * block_size * block_size, 0.0);
  return m;
}

void BlockSparseMatrix::SetZero() { std::fill(values_.begin(), values_.end(), 0.0); }

int64_t BlockSparseMatrix::FindBlock(int i, int k) const {
  if (i < 0 || i >= num_block_rows_ || k < i || k >= num_block_rows_) return -1;
  const auto first = block_cols_.begin() + row_start_[i];
  const auto last = block_cols_.begin() + row_start_[i + 1];
  const auto it = std::lower_bound(first, last, k);
  if (it == last || *it != k) return -1;
  return it - block_cols_.begin();
}

double* BlockSparseMatrix::MutableBlock(int i, int k) {
  const int64_t j = FindBlock(i, k);
  return j < 0 ? nullptr : values_.data() + j * block_size_ * block_size_;
}

const double* BlockSparseMatrix::Block(int i, int k) const {
  const int64_t j = FindBlock(i, k);
  return j < 0 ? nullptr : values_.data() + j * block_size_ * block_size_;
}

bool BlockSparseMatrix::HasBlock(int i, int k) const {
  return FindBlock(std::min(i, k), std::max(i, k)) >= 0;
}

bool BlockSparseMatrix::AddBlock(int i, int k, const Eigen::Ref<const Eigen::MatrixXd>& block) {
  const int b = block_size_;
  GS_CHECK(block.rows() == b && block.cols() == b);
  if (i <= k) {
    double* ik = MutableBlock(i, k);
    if (ik == nullptr) return false;
    for (int r = 0; r < b; ++r) {
      for (int c = 0; c < b; ++c) ik[r * b + c] += block(r, c);
    }
  } else {
    double* ki = MutableBlock(k, i);
    if (ki == nullptr) return false;
    for (int r = 0; r < b; ++r) {
      for (int c = 0; c < b; ++c) ki[r * b + c] += block(c, r);
    }
  }
  return true;
}

void BlockSparseMatrix::AddToDiagonal(const Eigen::VectorXd& d) {
  GS_CHECK(d.size() == num_rows());
  const int b = block_size_;
  for (int i = 0; i < num_block_rows_; ++i) {
    double* block = values_.data() + row_start_[i] * b * b;
    for (int r = 0; r < b; ++r) block[r * b + r] += d[static_cast<int64_t>(i) * b + r];
  }
}

Eigen::VectorXd BlockSparseMatrix::Diagonal() const {
  Eigen::VectorXd d(num_rows());
  const int b = block_size_;
  for (int i = 0; i < num_block_rows_; ++i) {
    const double* block = values_.data() + row_start_[i] * b * b;
    for (int r = 0; r < b; ++r) d[static_cast<int64_t>(i) * b + r] = block[r * b + r];
  }
  return d;
}

void BlockSparseMatrix::MultiplyRows(int begin, int end, const double* x, double* y) const {
  switch (block_size_) {
    case 3:
      MultiplyRowsFixed<3>(row_start_.data(), block_cols_.data(), col_start_.data(),
                           col_rows_.data(), col_blocks_.data(), values_.data(), begin, end, x, y);
      break;
    case 6:
      MultiplyRowsFixed<6>(row_start_.data(), block_cols_.data(), col_start_.data(),
                           col_rows_.data(), col_blocks_.data(), values_.data(), begin, end, x, y);
      break;
    default:
      MultiplyRowsDynamic(block_size_, row_start_.data(), block_cols_.data(), col_start_.data(),
                          col_rows_.data(), col_blocks_.data(), values_.data(), begin, end, x, y);
  }
}

void BlockSparseMatrix::RightMultiplyAndAccumulateSerial(const double* x, double* y) const {
  MultiplyRows(0, num_block_rows_, x, y);
}

void BlockSparseMatrix::RightMultiplyAndAccumulate(const double* x, double* y) const {
  if (num_block_rows_ < kMinBlockRowsForParallel) {
    MultiplyRows(0, num_block_rows_, x, y);
    return;
  }
  // Each task owns a disjoint range of output block rows; no reduction.
  tbb::parallel_for(tbb::blocked_range<int>(0, num_block_rows_, 64),
                    [&](const tbb::blocked_range<int>& range) {
                      MultiplyRows(range.begin(), range.end(), x, y);
                    });
}

Eigen::MatrixXd BlockSparseMatrix::ToDense() const {
  const int b = block_size_;
  using RowMajorMap =
      Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
  Eigen::MatrixXd dense = Eigen::MatrixXd::Zero(num_rows(), num_rows());
  for (int i = 0; i < num_block_rows_; ++i) {
    for (int64_t j = row_start_[i]; j < row_start_[i + 1]; ++j) {
      const Eigen::Index r = static_cast<Eigen::Index>(i) * b;
      const Eigen::Index c = static_cast<Eigen::Index>(block_cols_[j]) * b;
      const RowMajorMap u(values_.data() + j * b * b, b, b);
      dense.block(r, c, b, b) = u;
      if (c != r) dense.block(c, r, b, b) = u.transpose();
    }
  }
  return dense;
}

Eigen::SparseMatrix<double> BlockSparseMatrix::ToSparseUpper() const {
  // Column c = i*b + lc of the upper triangle holds A(r, c) for r <= c: column
  // lc of the stored blocks (k < i, i) of block column i (the transpose index,
  // rows ascending), then the diagonal block U_ii down to its diagonal.
  const int b = block_size_;
  const int n = num_rows();
  const int64_t nnz = (col_start_[num_block_rows_]) * b * b +
                      static_cast<int64_t>(num_block_rows_) * b * (b + 1) / 2;
  GS_CHECK(nnz <= std::numeric_limits<int>::max());

  Eigen::SparseMatrix<double> upper(n, n);
  upper.resizeNonZeros(static_cast<Eigen::Index>(nnz));
  int* outer = upper.outerIndexPtr();
  int* inner = upper.innerIndexPtr();
  double* value = upper.valuePtr();
  int64_t pos = 0;
  outer[0] = 0;
  for (int i = 0; i < num_block_rows_; ++i) {
    for (int lc = 0; lc < b; ++lc) {
      for (int64_t t = col_start_[i]; t < col_start_[i + 1]; ++t) {
        const int k = col_rows_[t];
        const double* column = values_.data() + static_cast<int64_t>(col_blocks_[t]) * b * b + lc;
        for (int lr = 0; lr < b; ++lr) {
          inner[pos] = k * b + lr;
          value[pos] = column[lr * b];
          ++pos;
        }
      }
      // The diagonal block is read along its row lc (as the former full
      // storage did), so a diagonal block that is symmetric only up to
      // rounding exports the same values as before.
      const double* diagonal = values_.data() + row_start_[i] * b * b + lc * b;
      for (int lr = 0; lr <= lc; ++lr) {
        inner[pos] = i * b + lr;
        value[pos] = diagonal[lr];
        ++pos;
      }
      outer[i * b + lc + 1] = static_cast<int>(pos);
    }
  }
  GS_CHECK(pos == nnz);
  return upper;
}

}  // namespace graphslam::core
