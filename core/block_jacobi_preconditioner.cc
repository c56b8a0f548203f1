#include "core/block_jacobi_preconditioner.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Cholesky>
#include <fmt/format.h>

#include "core/check.h"

namespace graphslam::core {
namespace {

constexpr int kMaxFixedBlockSize = 6;

// inverse = block^{-1} for a row-major symmetric b x b block, via LLT. Returns
// false if the block is not positive definite. Matrix is a fixed-capacity type
// for b <= kMaxFixedBlockSize (no allocation), MatrixXd otherwise.
template <typename Matrix>
bool InvertSpdBlock(const double* block, int b, double* inverse) {
  using RowMajorMap =
      Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
  const Matrix m = RowMajorMap(block, b, b);
  if (!m.allFinite()) return false;
  const Eigen::LLT<Matrix> llt(m);
  if (llt.info() != Eigen::Success) return false;
  Matrix inv = Matrix::Identity(b, b);
  llt.solveInPlace(inv);
  if (!inv.allFinite()) return false;
  // Symmetrize so that M^{-1} is exactly symmetric (PCG assumes it).
  for (int r = 0; r < b; ++r) {
    for (int c = 0; c < b; ++c) inverse[r * b + c] = 0.5 * (inv(r, c) + inv(c, r));
  }
  return true;
}

}  // namespace

Status BlockJacobiPreconditioner::Update(const BlockSparseMatrix& a) {
  const int b = a.block_size();
  const int n = a.num_block_rows();
  spare_.resize(static_cast<size_t>(n) * b * b);
  using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor,
                                    kMaxFixedBlockSize, kMaxFixedBlockSize>;
  for (int i = 0; i < n; ++i) {
    const double* block = a.Block(i, i);
    GS_CHECK(block != nullptr);  // every diagonal block is in the pattern
    double* inverse = spare_.data() + static_cast<int64_t>(i) * b * b;
    const bool ok = b <= kMaxFixedBlockSize ? InvertSpdBlock<SmallMatrix>(block, b, inverse)
                                            : InvertSpdBlock<Eigen::MatrixXd>(block, b, inverse);
    if (!ok) {
      return Status::Numerical(fmt::format(
          "block-Jacobi preconditioner: diagonal block of block row {} (scalar rows {}..{}) is "
          "not positive definite",
          i, static_cast<int64_t>(i) * b, static_cast<int64_t>(i) * b + b - 1));
    }
  }
  inverse_.swap(spare_);
  block_size_ = b;
  num_block_rows_ = n;
  return Status::Ok();
}

const double* BlockJacobiPreconditioner::InverseBlock(int i) const {
  GS_CHECK(i >= 0 && i < num_block_rows_);
  return inverse_.data() + static_cast<int64_t>(i) * block_size_ * block_size_;
}

void BlockJacobiPreconditioner::MultiplyRows(int begin, int end, const double* x,
                                             double* y) const {
  const int b = block_size_;
  for (int i = begin; i < end; ++i) {
    const double* block = inverse_.data() + static_cast<int64_t>(i) * b * b;
    const double* xi = x + static_cast<int64_t>(i) * b;
    double* yi = y + static_cast<int64_t>(i) * b;
    for (int r = 0; r < b; ++r) {
      double sum = 0.0;
      for (int c = 0; c < b; ++c) sum += block[r * b + c] * xi[c];
      yi[r] += sum;
    }
  }
}

void BlockJacobiPreconditioner::RightMultiplyAndAccumulate(const double* x, double* y) const {
  if (num_block_rows_ < BlockSparseMatrix::kMinBlockRowsForParallel) {
    MultiplyRows(0, num_block_rows_, x, y);
    return;
  }
  tbb::parallel_for(tbb::blocked_range<int>(0, num_block_rows_, 256),
                    [&](const tbb::blocked_range<int>& range) {
                      MultiplyRows(range.begin(), range.end(), x, y);
                    });
}

}  // namespace graphslam::core
