#include "core/block_sparse_matrix.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

#include "core/check.h"

namespace graphslam::core {
namespace {

// The sweep of one product range, rows [r0, r1): y_i += U_ik x_k for every
// stored block, and U_ik^T x_i into y_k (k < r1), into the window accumulator
// acc (r1 <= k < window_end) or nowhere (far, gathered by MergeRows). kB > 0:
// the block size known at compile time (the direct sum of a row stays in
// registers); kB == 0: any block size b, accumulated in place.
template <int kB>
void SweepRows(int b_runtime, const int64_t* row_start, const int* block_cols,
               const double* values, int r0, int r1, int window_end, const double* x, double* y,
               double* acc) {
  const int b = kB > 0 ? kB : b_runtime;
  const int64_t bb = static_cast<int64_t>(b) * b;
  for (int i = r0; i < r1; ++i) {
    const double* xi = x + static_cast<int64_t>(i) * b;
    double* yi = y + static_cast<int64_t>(i) * b;
    double sum[kB > 0 ? kB : 1];
    if constexpr (kB > 0) {
      for (int r = 0; r < kB; ++r) sum[r] = 0.0;
    }
    for (int64_t j = row_start[i]; j < row_start[i + 1]; ++j) {
      const int k = block_cols[j];
      const double* u = values + j * bb;
      const double* xk = x + static_cast<int64_t>(k) * b;
      for (int r = 0; r < b; ++r) {
        double s = 0.0;
        for (int c = 0; c < b; ++c) s += u[r * b + c] * xk[c];
        if constexpr (kB > 0) {
          sum[r] += s;
        } else {
          yi[r] += s;
        }
      }
      if (k == i || k >= window_end) continue;  // diagonal, or far
      double* target = k < r1 ? y + static_cast<int64_t>(k) * b
                              : acc + static_cast<int64_t>(k - r1) * b;
      for (int c = 0; c < b; ++c) {
        double s = 0.0;
        for (int r = 0; r < b; ++r) s += u[r * b + c] * xi[r];
        target[c] += s;
      }
    }
    if constexpr (kB > 0) {
      for (int r = 0; r < kB; ++r) yi[r] += sum[r];
    }
  }
}

// The far blocks of one merge range: y_k += sum_i U_ik^T x_i over the
// entries [begin, end), sorted by (k, i).
template <int kB>
void GatherFar(int b_runtime, const int* far_rows, const int* far_cols, const int* far_blocks,
               const double* values, int64_t begin, int64_t end, const double* x, double* y) {
  const int b = kB > 0 ? kB : b_runtime;
  const int64_t bb = static_cast<int64_t>(b) * b;
  int64_t e = begin;
  while (e < end) {
    const int k = far_cols[e];
    double* yk = y + static_cast<int64_t>(k) * b;
    double sum[kB > 0 ? kB : 1];
    if constexpr (kB > 0) {
      for (int c = 0; c < kB; ++c) sum[c] = 0.0;
    }
    for (; e < end && far_cols[e] == k; ++e) {
      const double* u = values + static_cast<int64_t>(far_blocks[e]) * bb;
      const double* xi = x + static_cast<int64_t>(far_rows[e]) * b;
      for (int c = 0; c < b; ++c) {
        double s = 0.0;
        for (int r = 0; r < b; ++r) s += u[r * b + c] * xi[r];
        if constexpr (kB > 0) {
          sum[c] += s;
        } else {
          yk[c] += s;
        }
      }
    }
    if constexpr (kB > 0) {
      for (int c = 0; c < kB; ++c) yk[c] += sum[c];
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
  m.PartitionForProduct(
      std::max<int64_t>(1, kProductNonzerosPerRange / (static_cast<int64_t>(block_size) * block_size)));
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

void BlockSparseMatrix::PartitionForProduct(int64_t stored_blocks_per_range) {
  GS_CHECK(stored_blocks_per_range >= 1);
  const int n = num_block_rows_;
  const int b = block_size_;
  range_start_.assign(1, 0);
  for (int i = 0; i < n; ++i) {
    if (row_start_[i + 1] - row_start_[range_start_.back()] >= stored_blocks_per_range ||
        i + 1 == n) {
      range_start_.push_back(i + 1);
    }
  }
  const int num_ranges = static_cast<int>(range_start_.size()) - 1;

  // Windows. A window row costs about 4 b doubles of traffic per product
  // (zeroed, accumulated, read and added to y by the merge); a far block
  // costs a second read of its b^2 values and of x_i, scattered: about 2 b^2.
  // Each range takes the W in [0, min(2 len, n - r1)] minimizing
  //   4 b W + 2 b^2 (blocks with k >= r1 + W),
  // over the offsets k - r1 of its own blocks (W = 0: everything beyond r1 far).
  window_start_.assign(static_cast<size_t>(num_ranges) + 1, 0);
  std::vector<int> window_rows(static_cast<size_t>(num_ranges), 0);
  std::vector<int> offsets;
  for (int r = 0; r < num_ranges; ++r) {
    const int r0 = range_start_[r], r1 = range_start_[r + 1];
    offsets.clear();
    for (int64_t j = row_start_[r0]; j < row_start_[r1]; ++j) {
      if (block_cols_[j] >= r1) offsets.push_back(block_cols_[j] - r1);
    }
    std::sort(offsets.begin(), offsets.end());
    const int64_t cap = std::min<int64_t>(2 * static_cast<int64_t>(r1 - r0), n - r1);
    const int64_t total = static_cast<int64_t>(offsets.size());
    double best_cost = 2.0 * b * b * static_cast<double>(total);
    int best = 0;
    for (int64_t m = 0; m < total && offsets[m] < cap; ++m) {
      if (m + 1 < total && offsets[m + 1] == offsets[m]) continue;  // last of equal offsets
      const double cost = 4.0 * b * (offsets[m] + 1.0) + 2.0 * b * b * static_cast<double>(total - m - 1);
      if (cost < best_cost) {
        best_cost = cost;
        best = offsets[m] + 1;
      }
    }
    window_rows[r] = best;
    window_start_[r + 1] = window_start_[r] + best;
  }

  // Far blocks, counting-sorted by column; rows ascending within a column
  // because the rows are visited in order.
  std::vector<int64_t> count(static_cast<size_t>(n) + 1, 0);
  auto for_each_far = [&](auto&& visit) {
    for (int r = 0; r < num_ranges; ++r) {
      const int r1 = range_start_[r + 1];
      const int window_end = r1 + window_rows[r];
      for (int i = range_start_[r]; i < r1; ++i) {
        for (int64_t j = row_start_[i] + 1; j < row_start_[i + 1]; ++j) {
          if (block_cols_[j] >= window_end) visit(i, block_cols_[j], j);
        }
      }
    }
  };
  for_each_far([&](int, int k, int64_t) { ++count[k + 1]; });
  for (int k = 0; k < n; ++k) count[k + 1] += count[k];
  const int64_t num_far = n > 0 ? count[n] : 0;
  far_rows_.assign(num_far, 0);
  far_cols_.assign(num_far, 0);
  far_blocks_.assign(num_far, 0);
  far_start_.assign(static_cast<size_t>(num_ranges) + 1, 0);
  for (int q = 0; q <= num_ranges; ++q) far_start_[q] = count[range_start_[q]];
  for_each_far([&](int i, int k, int64_t j) {
    const int64_t t = count[k]++;
    far_rows_[t] = i;
    far_cols_[t] = k;
    far_blocks_[t] = static_cast<int>(j);
  });

  // For each range q, the earlier windows that reach into it.
  merge_start_.assign(static_cast<size_t>(num_ranges) + 1, 0);
  merge_ranges_.clear();
  for (int q = 0; q < num_ranges; ++q) {
    for (int r = 0; r < q; ++r) {
      if (range_start_[r + 1] + window_rows[r] > range_start_[q]) merge_ranges_.push_back(r);
    }
    merge_start_[q + 1] = static_cast<int>(merge_ranges_.size());
  }
  scratch_.values.assign(static_cast<size_t>(window_start_.back()) * b, 0.0);
}

void BlockSparseMatrix::SweepRange(int r, const double* x, double* y, double* acc) const {
  const int b = block_size_;
  const int r0 = range_start_[r], r1 = range_start_[r + 1];
  const int64_t w = window_start_[r + 1] - window_start_[r];
  double* window = acc + window_start_[r] * b;
  std::fill(window, window + w * b, 0.0);
  const int window_end = r1 + static_cast<int>(w);
  switch (b) {
    case 3:
      SweepRows<3>(b, row_start_.data(), block_cols_.data(), values_.data(), r0, r1, window_end, x,
                   y, window);
      break;
    case 6:
      SweepRows<6>(b, row_start_.data(), block_cols_.data(), values_.data(), r0, r1, window_end, x,
                   y, window);
      break;
    default:
      SweepRows<0>(b, row_start_.data(), block_cols_.data(), values_.data(), r0, r1, window_end, x,
                   y, window);
  }
}

void BlockSparseMatrix::MergeRange(int q, const double* x, double* y, const double* acc) const {
  const int b = block_size_;
  const int q0 = range_start_[q], q1 = range_start_[q + 1];
  // Earlier windows, ascending range.
  for (int m = merge_start_[q]; m < merge_start_[q + 1]; ++m) {
    const int r = merge_ranges_[m];
    const int w0 = range_start_[r + 1];
    const int w1 = w0 + static_cast<int>(window_start_[r + 1] - window_start_[r]);
    const int lo = std::max(q0, w0), hi = std::min(q1, w1);
    const double* window = acc + (window_start_[r] + (lo - w0)) * b;
    double* out = y + static_cast<int64_t>(lo) * b;
    const int64_t len = static_cast<int64_t>(hi - lo) * b;
    for (int64_t t = 0; t < len; ++t) out[t] += window[t];
  }
  // Then the far blocks.
  const int64_t begin = far_start_[q], end = far_start_[q + 1];
  if (begin == end) return;
  switch (b) {
    case 3:
      GatherFar<3>(b, far_rows_.data(), far_cols_.data(), far_blocks_.data(), values_.data(), begin,
                   end, x, y);
      break;
    case 6:
      GatherFar<6>(b, far_rows_.data(), far_cols_.data(), far_blocks_.data(), values_.data(), begin,
                   end, x, y);
      break;
    default:
      GatherFar<0>(b, far_rows_.data(), far_cols_.data(), far_blocks_.data(), values_.data(), begin,
                   end, x, y);
  }
}

void BlockSparseMatrix::Multiply(const double* x, double* y, bool parallel) const {
  const int num_ranges = num_product_ranges();
  if (num_ranges <= 0) return;
  // The shared accumulators, or (a concurrent caller) private ones.
  std::unique_lock<std::mutex> lock(scratch_.mutex, std::try_to_lock);
  std::vector<double> own;
  double* acc = scratch_.values.data();
  if (!lock.owns_lock()) {
    own.assign(scratch_.values.size(), 0.0);
    acc = own.data();
  }
  if (!parallel || num_ranges == 1) {
    for (int r = 0; r < num_ranges; ++r) SweepRange(r, x, y, acc);
    for (int q = 1; q < num_ranges; ++q) MergeRange(q, x, y, acc);
    return;
  }
  // Phase 1: range r writes only its own rows of y and its own window.
  tbb::parallel_for(tbb::blocked_range<int>(0, num_ranges, 1),
                    [&](const tbb::blocked_range<int>& range) {
                      for (int r = range.begin(); r < range.end(); ++r) SweepRange(r, x, y, acc);
                    });
  // Phase 2: range q adds the windows and far blocks into its own rows.
  tbb::parallel_for(tbb::blocked_range<int>(1, num_ranges, 1),
                    [&](const tbb::blocked_range<int>& range) {
                      for (int q = range.begin(); q < range.end(); ++q) MergeRange(q, x, y, acc);
                    });
}

void BlockSparseMatrix::RightMultiplyAndAccumulateSerial(const double* x, double* y) const {
  Multiply(x, y, /*parallel=*/false);
}

void BlockSparseMatrix::RightMultiplyAndAccumulate(const double* x, double* y) const {
  Multiply(x, y, /*parallel=*/true);
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
