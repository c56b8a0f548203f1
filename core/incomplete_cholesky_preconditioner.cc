#include "core/incomplete_cholesky_preconditioner.h"

#include <Eigen/IterativeLinearSolvers>
#include <Eigen/OrderingMethods>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <limits>
#include <mutex>
#include <vector>

#include "core/check.h"

namespace graphslam::core {
namespace {

using EigenIncompleteCholesky =
    Eigen::IncompleteCholesky<double, Eigen::Lower, Eigen::AMDOrdering<int>>;

// Eigen 3.4 IncompleteCholesky::factorize gives up after this many shifted
// attempts (the `++iter >= 10` in IncompleteCholesky.h).
constexpr int kEigenMaxShiftAttempts = 10;

// The lower triangle of A, column-major with sorted rows, stored on the block
// pattern of A^(fill_levels + 1): entries of A where A has them, explicit zeros
// elsewhere. Eigen keeps in column j of L as many entries as column j of its
// input has, explicit zeros included, so the zeros are fill budget -- Lin &
// More's memory parameter p, spent on the largest fill entries wherever they
// appear. fill_levels = 0 is A itself.
Eigen::SparseMatrix<double> LowerWithFillBudget(const BlockSparseMatrix& a, int fill_levels) {
  const int b = a.block_size();
  const int num_blocks = a.num_block_rows();
  const std::vector<int64_t>& row_start = a.row_start();
  const std::vector<int>& block_cols = a.block_cols();
  const std::vector<int64_t>& col_start = a.col_start();
  const std::vector<int>& col_rows = a.col_rows();

  // reach[i]: block columns k >= i within fill_levels + 1 edges of i (sorted).
  // Breadth-first over the block graph, with `mark` as the visited set.
  std::vector<std::vector<int>> reach(static_cast<size_t>(num_blocks));
  std::vector<int> mark(static_cast<size_t>(num_blocks), -1);
  std::vector<int> frontier, next, visited;
  for (int i = 0; i < num_blocks; ++i) {
    frontier.assign(1, i);
    visited.assign(1, i);
    mark[i] = i;
    for (int level = 0; level <= fill_levels && !frontier.empty(); ++level) {
      next.clear();
      // The neighbours of v: the stored upper blocks of row v and, through
      // the transpose index, those of column v.
      auto visit = [&](int k) {
        if (mark[k] == i) return;
        mark[k] = i;
        next.push_back(k);
        visited.push_back(k);
      };
      for (int v : frontier) {
        for (int64_t t = col_start[v]; t < col_start[v + 1]; ++t) visit(col_rows[t]);
        for (int64_t j = row_start[v]; j < row_start[v + 1]; ++j) visit(block_cols[j]);
      }
      frontier.swap(next);
    }
    std::vector<int>& columns = reach[i];
    for (int k : visited)
      if (k >= i) columns.push_back(k);
    std::sort(columns.begin(), columns.end());
  }

  int64_t nnz = 0;
  for (int i = 0; i < num_blocks; ++i) {
    nnz += static_cast<int64_t>(reach[i].size() - 1) * b * b + static_cast<int64_t>(b) * (b + 1) / 2;
  }
  GS_CHECK(nnz <= std::numeric_limits<int>::max());
  const int n = a.num_rows();
  Eigen::SparseMatrix<double> lower(n, n);
  lower.resizeNonZeros(static_cast<Eigen::Index>(nnz));
  int* outer = lower.outerIndexPtr();
  int* inner = lower.innerIndexPtr();
  double* value = lower.valuePtr();
  int64_t pos = 0;
  outer[0] = 0;
  for (int i = 0; i < num_blocks; ++i) {
    for (int lc = 0; lc < b; ++lc) {
      // Column i*b + lc below the diagonal is, by symmetry, row i*b + lc of A
      // to the right of it: row lc of the row-major blocks (i, k), k >= i.
      for (int k : reach[i]) {
        const double* block = a.Block(i, k);  // nullptr: fill budget only
        for (int lr = (k == i) ? lc : 0; lr < b; ++lr) {
          inner[pos] = k * b + lr;
          value[pos] = block != nullptr ? block[lc * b + lr] : 0.0;
          ++pos;
        }
      }
      outer[i * b + lc + 1] = static_cast<int>(pos);
    }
  }
  GS_CHECK(pos == nnz);
  return lower;
}

}  // namespace

struct IncompleteCholeskyPreconditioner::Factor {
  EigenIncompleteCholesky incomplete_cholesky;
  // Scratch for the triangular solves; RightMultiplyAndAccumulate holds
  // `mutex` while it uses it.
  mutable std::mutex mutex;
  mutable std::vector<double> scratch;  // GUARDED_BY(mutex), num_rows entries
};

Status IncompleteCholeskyOptions::Validate() const {
  if (!(initial_shift > 0.0) || !std::isfinite(initial_shift)) {
    return Status::InvalidArgument(fmt::format(
        "IncompleteCholeskyOptions.initial_shift must be positive and finite, got {:g}",
        initial_shift));
  }
  if (fill_levels < 0 || fill_levels > kMaxFillLevels) {
    return Status::InvalidArgument(
        fmt::format("IncompleteCholeskyOptions.fill_levels must be in [0, {}], got {}",
                    kMaxFillLevels, fill_levels));
  }
  return Status::Ok();
}

IncompleteCholeskyPreconditioner::IncompleteCholeskyPreconditioner(
    const IncompleteCholeskyOptions& options)
    : options_(options) {}

IncompleteCholeskyPreconditioner::~IncompleteCholeskyPreconditioner() = default;
IncompleteCholeskyPreconditioner::IncompleteCholeskyPreconditioner(
    IncompleteCholeskyPreconditioner&&) noexcept = default;
IncompleteCholeskyPreconditioner& IncompleteCholeskyPreconditioner::operator=(
    IncompleteCholeskyPreconditioner&&) noexcept = default;

Status IncompleteCholeskyPreconditioner::Update(const BlockSparseMatrix& a) {
  GS_RETURN_IF_ERROR(options_.Validate());
  const int n = a.num_rows();
  const int b = a.block_size();
  const Eigen::SparseMatrix<double> lower = LowerWithFillBudget(a, options_.fill_levels);

  // Input checks Eigen does not make: a NaN pivot passes its `diag <= 0`
  // test, and a non-positive diagonal is silently shifted away.
  for (int c = 0; c < n; ++c) {
    for (Eigen::SparseMatrix<double>::InnerIterator it(lower, c); it; ++it) {
      const int r = static_cast<int>(it.row());
      if (!std::isfinite(it.value())) {
        return Status::Numerical(fmt::format(
            "incomplete Cholesky preconditioner: A({}, {}) = {} is not finite (block ({}, {}))", r,
            c, it.value(), r / b, c / b));
      }
      if (r == c && !(it.value() > 0.0)) {
        return Status::Numerical(fmt::format(
            "incomplete Cholesky preconditioner: diagonal entry A({}, {}) = {:g} of block row {} "
            "is not positive; A is not positive definite",
            r, c, it.value(), r / b));
      }
    }
  }

  if (spare_ == nullptr) spare_ = std::make_unique<Factor>();
  EigenIncompleteCholesky& factorization = spare_->incomplete_cholesky;
  factorization.setInitialShift(options_.initial_shift);
  if (n > 0) {  // Eigen 3.4 sizes a work vector n - 1 and asserts on n = 0
    factorization.compute(lower);
    if (factorization.info() != Eigen::Success) {
      return Status::Numerical(fmt::format(
          "incomplete Cholesky preconditioner: Eigen::IncompleteCholesky reported "
          "NumericalIssue on a {} x {} matrix ({} block rows): a pivot of S P A P^T S stayed <= 0 "
          "in all {} attempts (diagonal shift 0, then doubling from initial_shift = {:g} to {:g}); "
          "A is probably indefinite (or raise initial_shift)",
          n, n, a.num_block_rows(), kEigenMaxShiftAttempts, options_.initial_shift,
          options_.initial_shift * std::ldexp(1.0, kEigenMaxShiftAttempts - 2)));
    }
    const auto& l = factorization.matrixL();
    // RightMultiplyAndAccumulate walks the raw CSC arrays and relies on
    // Eigen putting the diagonal first in every column.
    GS_CHECK(l.isCompressed() && l.rows() == n && l.cols() == n);
    GS_CHECK(factorization.scalingS().size() == n);
    const int* outer = l.outerIndexPtr();
    const int* inner = l.innerIndexPtr();
    const double* value = l.valuePtr();
    for (int j = 0; j < n; ++j) {
      GS_CHECK(outer[j] < outer[j + 1] && inner[outer[j]] == j);
      for (int k = outer[j]; k < outer[j + 1]; ++k) {
        if (!std::isfinite(value[k]) || (k == outer[j] && !(value[k] > 0.0))) {
          return Status::Numerical(fmt::format(
              "incomplete Cholesky preconditioner: factor entry L({}, {}) = {} (permuted "
              "order) is not finite and positive",
              inner[k], j, value[k]));
        }
      }
    }
  }
  spare_->scratch.assign(static_cast<size_t>(n), 0.0);
  factor_.swap(spare_);
  num_rows_ = n;
  num_pattern_nonzeros_ = lower.nonZeros();
  return Status::Ok();
}

int64_t IncompleteCholeskyPreconditioner::num_factor_nonzeros() const {
  if (factor_ == nullptr || num_rows_ == 0) return 0;
  return factor_->incomplete_cholesky.matrixL().nonZeros();
}

void IncompleteCholeskyPreconditioner::RightMultiplyAndAccumulate(const double* x,
                                                                  double* y) const {
  GS_CHECK(factor_ != nullptr);
  const int n = num_rows_;
  if (n == 0) return;
  const EigenIncompleteCholesky& factorization = factor_->incomplete_cholesky;
  const auto& l = factorization.matrixL();
  const int* outer = l.outerIndexPtr();
  const int* inner = l.innerIndexPtr();
  const double* value = l.valuePtr();
  const double* scale = factorization.scalingS().data();
  const auto& permutation = factorization.permutationP().indices();
  const bool permuted = permutation.size() == n;  // Eigen leaves it empty if identity

  std::lock_guard<std::mutex> lock(factor_->mutex);
  double* t = factor_->scratch.data();
  // t = S P x, with (P x)[perm[i]] = x[i] (Eigen's PermutationMatrix product).
  for (int i = 0; i < n; ++i) {
    const int p = permuted ? permutation[i] : i;
    t[p] = scale[p] * x[i];
  }
  // t <- L^{-1} t: column-oriented forward substitution, diagonal first.
  for (int j = 0; j < n; ++j) {
    const double tj = t[j] / value[outer[j]];
    t[j] = tj;
    for (int k = outer[j] + 1; k < outer[j + 1]; ++k) t[inner[k]] -= value[k] * tj;
  }
  // t <- L^{-T} t: column j of L is row j of L^T, so a dot product per row.
  for (int j = n - 1; j >= 0; --j) {
    double sum = t[j];
    for (int k = outer[j] + 1; k < outer[j + 1]; ++k) sum -= value[k] * t[inner[k]];
    t[j] = sum / value[outer[j]];
  }
  // y += P^T S t.
  for (int i = 0; i < n; ++i) {
    const int p = permuted ? permutation[i] : i;
    y[i] += scale[p] * t[p];
  }
}

}  // namespace graphslam::core
