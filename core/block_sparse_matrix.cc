#include "core/block_sparse_matrix.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <limits>

#include "core/check.h"

namespace graphslam::core {
namespace {

// The sweep of one product range, rows [r0, r1): y_i += U_ik x_k for every
// stored block, and U_ik^T x_i into y_k (k < r1), into the range's
// accumulator slot slots[cursor++] (r1 <= k < far_from) or nowhere (far,
// gathered by GatherFar). kB > 0: the block size known at compile time (the
// direct sum of a row stays in registers); kB == 0: any block size b,
// accumulated in place.
template <int kB>
void SweepRows(int b_runtime, const int64_t* row_start, const int* block_cols,
               const double* values, int r0, int r1, int far_from, const int* slots,
               const double* x, double* y, double* acc) {
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
      if (k == i || k >= far_from) continue;  // diagonal, or far
      double* target = k < r1 ? y + static_cast<int64_t>(k) * b
                              : acc + static_cast<int64_t>(*slots++) * b;
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

// The far blocks of one merge range: y_k += U_ik^T x_i for the entries
// [begin, end), in storage order (ascending i, then k): the values and x are
// read forward, the scattered writes stay within the merge range's rows.
template <int kB>
void GatherFar(int b_runtime, const int* far_rows, const int* far_cols, const int* far_blocks,
               const double* values, int64_t begin, int64_t end, const double* x, double* y) {
  const int b = kB > 0 ? kB : b_runtime;
  const int64_t bb = static_cast<int64_t>(b) * b;
  for (int64_t e = begin; e < end; ++e) {
    const double* u = values + static_cast<int64_t>(far_blocks[e]) * bb;
    const double* xi = x + static_cast<int64_t>(far_rows[e]) * b;
    double* yk = y + static_cast<int64_t>(far_cols[e]) * b;
    for (int c = 0; c < b; ++c) {
      double s = 0.0;
      for (int r = 0; r < b; ++r) s += u[r * b + c] * xi[r];
      yk[c] += s;
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
  if (k == i) return row_start_[i];  // every row stores its diagonal block first
  const auto first = block_cols_.begin() + row_start_[i] + 1;
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

namespace {

// dst (row-major b x b) += block, or += block^T; B the block size when it is
// known at compile time (the pose blocks: 3 in the plane, 6 in 3-D), else 0.
template <int B>
void AddInto(int b, const Eigen::Ref<const Eigen::MatrixXd>& block, bool transpose,
             double* dst) {
  const int n = B > 0 ? B : b;
  if (transpose) {
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c) dst[r * n + c] += block(c, r);
  } else {
    for (int r = 0; r < n; ++r)
      for (int c = 0; c < n; ++c) dst[r * n + c] += block(r, c);
  }
}

}  // namespace

bool BlockSparseMatrix::AddBlock(int i, int k, const Eigen::Ref<const Eigen::MatrixXd>& block) {
  const int b = block_size_;
  GS_CHECK(block.rows() == b && block.cols() == b);
  const bool transpose = i > k;
  double* dst = transpose ? MutableBlock(k, i) : MutableBlock(i, k);
  if (dst == nullptr) return false;
  switch (b) {
    case 3:
      AddInto<3>(b, block, transpose, dst);
      break;
    case 6:
      AddInto<6>(b, block, transpose, dst);
      break;
    default:
      AddInto<0>(b, block, transpose, dst);
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

  // Accumulators. Range r's accumulator has one slot per distinct row
  // k >= r1 its blocks reach, nearest first, at most 4 (r1 - r0) of them (so
  // all together hold at most 4 num_rows() doubles); blocks reaching beyond
  // the last slot (far_from_[r]) are far. On a band every row is a slot; the
  // cap only bites where a range touches more distinct rows than 4x its own.
  target_start_.assign(static_cast<size_t>(num_ranges) + 1, 0);
  target_rows_.clear();
  far_from_.assign(static_cast<size_t>(num_ranges), n);
  std::vector<int> targets;
  for (int r = 0; r < num_ranges; ++r) {
    const int r0 = range_start_[r], r1 = range_start_[r + 1];
    targets.clear();
    for (int64_t j = row_start_[r0]; j < row_start_[r1]; ++j) {
      if (block_cols_[j] >= r1) targets.push_back(block_cols_[j]);
    }
    std::sort(targets.begin(), targets.end());
    targets.erase(std::unique(targets.begin(), targets.end()), targets.end());
    const size_t cap = 4 * static_cast<size_t>(r1 - r0);
    if (targets.size() > cap) {
      far_from_[r] = targets[cap];
      targets.resize(cap);
    }
    target_rows_.insert(target_rows_.end(), targets.begin(), targets.end());
    target_start_[r + 1] = static_cast<int64_t>(target_rows_.size());
  }
  // The slot of every accumulated block, in sweep order.
  slot_start_.assign(static_cast<size_t>(num_ranges) + 1, 0);
  slots_.clear();
  for (int r = 0; r < num_ranges; ++r) {
    const int r1 = range_start_[r + 1];
    const auto first = target_rows_.begin() + target_start_[r];
    const auto last = target_rows_.begin() + target_start_[r + 1];
    for (int i = range_start_[r]; i < r1; ++i) {
      for (int64_t j = row_start_[i] + 1; j < row_start_[i + 1]; ++j) {
        const int k = block_cols_[j];
        if (k < r1 || k >= far_from_[r]) continue;
        slots_.push_back(static_cast<int>(std::lower_bound(first, last, k) - first));
      }
    }
    slot_start_[r + 1] = static_cast<int64_t>(slots_.size());
  }
  slots_.shrink_to_fit();
  target_rows_.shrink_to_fit();

  // Far blocks, counting-sorted by the range of their column k; within a
  // range in storage order (rows ascending, then k), as visited.
  std::vector<int> range_of(static_cast<size_t>(n));
  for (int r = 0; r < num_ranges; ++r) {
    std::fill(range_of.begin() + range_start_[r], range_of.begin() + range_start_[r + 1], r);
  }
  std::vector<int64_t> count(static_cast<size_t>(num_ranges) + 1, 0);
  auto for_each_far = [&](auto&& visit) {
    for (int r = 0; r < num_ranges; ++r) {
      const int r1 = range_start_[r + 1];
      for (int i = range_start_[r]; i < r1; ++i) {
        for (int64_t j = row_start_[i] + 1; j < row_start_[i + 1]; ++j) {
          if (block_cols_[j] >= far_from_[r]) visit(i, block_cols_[j], j);
        }
      }
    }
  };
  for_each_far([&](int, int k, int64_t) { ++count[range_of[k] + 1]; });
  for (int q = 0; q < num_ranges; ++q) count[q + 1] += count[q];
  const int64_t num_far = count[num_ranges];
  far_start_ = count;
  far_rows_.assign(num_far, 0);
  far_cols_.assign(num_far, 0);
  far_blocks_.assign(num_far, 0);
  for_each_far([&](int i, int k, int64_t j) {
    const int64_t t = count[range_of[k]]++;
    far_rows_[t] = i;
    far_cols_[t] = k;
    far_blocks_[t] = static_cast<int>(j);
  });

  // For each range q, the runs of earlier accumulators' slots whose rows lie
  // in q: counting-sorted by q, ascending r within q as visited.
  std::vector<std::pair<int, int>> runs;  // (q, first slot position)
  std::vector<int64_t> run_count(static_cast<size_t>(num_ranges) + 1, 0);
  for (int r = 0; r < num_ranges; ++r) {
    for (int64_t t = target_start_[r]; t < target_start_[r + 1]; ++t) {
      const int q = range_of[target_rows_[t]];
      if (t == target_start_[r] || q != range_of[target_rows_[t - 1]]) ++run_count[q + 1];
    }
  }
  for (int q = 0; q < num_ranges; ++q) run_count[q + 1] += run_count[q];
  merge_start_ = run_count;
  merge_runs_.assign(static_cast<size_t>(run_count[num_ranges]), MergeRun{});
  for (int r = 0; r < num_ranges; ++r) {
    for (int64_t t = target_start_[r]; t < target_start_[r + 1]; ++t) {
      const int q = range_of[target_rows_[t]];
      if (t == target_start_[r] || q != range_of[target_rows_[t - 1]]) {
        merge_runs_[run_count[q]++] = MergeRun{t, t + 1};
      } else {
        ++merge_runs_[run_count[q] - 1].end;
      }
    }
  }
  scratch_.values.assign(static_cast<size_t>(target_start_.back()) * b, 0.0);
}

void BlockSparseMatrix::SweepRange(int r, const double* x, double* y, double* acc) const {
  const int b = block_size_;
  const int r0 = range_start_[r], r1 = range_start_[r + 1];
  double* own = acc + target_start_[r] * b;
  std::fill(own, acc + target_start_[r + 1] * b, 0.0);
  const int* slots = slots_.data() + slot_start_[r];
  switch (b) {
    case 3:
      SweepRows<3>(b, row_start_.data(), block_cols_.data(), values_.data(), r0, r1, far_from_[r],
                   slots, x, y, own);
      break;
    case 6:
      SweepRows<6>(b, row_start_.data(), block_cols_.data(), values_.data(), r0, r1, far_from_[r],
                   slots, x, y, own);
      break;
    default:
      SweepRows<0>(b, row_start_.data(), block_cols_.data(), values_.data(), r0, r1, far_from_[r],
                   slots, x, y, own);
  }
}

void BlockSparseMatrix::MergeRange(int q, const double* x, double* y, const double* acc) const {
  const int b = block_size_;
  // Earlier accumulators, ascending range: slot t holds row target_rows_[t].
  for (int64_t m = merge_start_[q]; m < merge_start_[q + 1]; ++m) {
    for (int64_t t = merge_runs_[m].begin; t < merge_runs_[m].end; ++t) {
      double* out = y + static_cast<int64_t>(target_rows_[t]) * b;
      const double* in = acc + t * b;
      for (int c = 0; c < b; ++c) out[c] += in[c];
    }
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
  // Phase 1: range r writes only its own rows of y and its own accumulator.
  tbb::parallel_for(tbb::blocked_range<int>(0, num_ranges, 1),
                    [&](const tbb::blocked_range<int>& range) {
                      for (int r = range.begin(); r < range.end(); ++r) SweepRange(r, x, y, acc);
                    });
  // Phase 2: range q adds the accumulators' slots and far blocks into its own rows.
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
