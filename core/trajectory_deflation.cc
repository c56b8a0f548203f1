#include "core/trajectory_deflation.h"

#include <algorithm>
#include <fmt/format.h>
#include <utility>

#include "core/check.h"

namespace graphslam::core {

std::vector<int> TrajectoryDeflation::DefaultLinearComponents(int block_size) {
  if (block_size == 3) return {1};  // SE(2) body frame (x forward, y left, theta): y
  std::vector<int> all(static_cast<size_t>(block_size));
  for (int d = 0; d < block_size; ++d) all[d] = d;
  return all;
}

TrajectoryDeflation::TrajectoryDeflation(const LinearOperator* inner, int poses_per_aggregate,
                                         std::vector<int> linear_components)
    : inner_(inner),
      poses_per_aggregate_(poses_per_aggregate),
      linear_(std::move(linear_components)) {
  GS_CHECK(inner != nullptr && poses_per_aggregate >= 2);
}

Status TrajectoryDeflation::Update(const BlockSparseMatrix& s) {
  if (inner_->num_rows() != s.num_rows()) {
    return Status::InvalidArgument(fmt::format(
        "trajectory deflation: the inner preconditioner has {} rows, S {}", inner_->num_rows(),
        s.num_rows()));
  }
  const int nb = s.num_block_rows();
  const int b = s.block_size();
  const int m = poses_per_aggregate_;
  for (const int d : linear_) {
    if (d < 0 || d >= b) {
      return Status::InvalidArgument(fmt::format(
          "trajectory deflation: linear mode of component {} in blocks of size {}", d, b));
    }
  }
  std::lock_guard<std::mutex> lock(mutex_);
  num_rows_ = s.num_rows();
  block_size_ = b;
  num_blocks_ = nb;
  inner_result_.assign(static_cast<size_t>(num_rows_), 0.0);
  if (nb < 2) {
    num_aggregates_ = 0;
    return Status::Ok();
  }
  // Aggregates of m consecutive poses; the last one takes the remainder.
  const int na = std::max(1, nb / m);
  aggregate_.resize(static_cast<size_t>(nb));
  t_.resize(static_cast<size_t>(nb));
  for (int a = 0; a < na; ++a) {
    const int lo = a * m, hi = a == na - 1 ? nb - 1 : lo + m - 1;
    const double centre = 0.5 * (lo + hi);
    for (int i = lo; i <= hi; ++i) {
      aggregate_[i] = a;
      t_[i] = (i - centre) / m;
    }
  }

  // S W: block (i, a) = sum over k in a of S_ik W_k, W_k = [I, t_k P]
  // (b x wb). The columns k of a block row are sorted, so their aggregates
  // are too.
  const int num_linear = static_cast<int>(linear_.size());
  const int wb = b + num_linear;
  width_ = wb;
  const std::vector<int64_t>& row_start = s.row_start();
  const std::vector<int>& cols = s.block_cols();
  const std::vector<int64_t>& col_start = s.col_start();
  const std::vector<int>& col_rows = s.col_rows();
  const std::vector<int>& col_blocks = s.col_blocks();
  sw_row_start_.assign(static_cast<size_t>(nb) + 1, 0);
  sw_cols_.clear();
  sw_values_.clear();
  for (int i = 0; i < nb; ++i) {
    // S_ik (row-major element (r, c) at block[r * rs + c * cs]): U_ki^T for
    // k < i through the transpose index, then U_ik; ascending k.
    auto add_block = [&](int k, const double* block, int rs, int cs) {
      const int a = aggregate_[k];
      if (static_cast<int64_t>(sw_cols_.size()) == sw_row_start_[i] || sw_cols_.back() != a) {
        sw_cols_.push_back(a);
        sw_values_.resize(sw_values_.size() + static_cast<size_t>(b) * wb, 0.0);
      }
      double* out = sw_values_.data() + sw_values_.size() - static_cast<size_t>(b) * wb;
      for (int r = 0; r < b; ++r) {
        for (int c = 0; c < b; ++c) out[r * wb + c] += block[r * rs + c * cs];
        for (int l = 0; l < num_linear; ++l) {
          out[r * wb + b + l] += t_[k] * block[r * rs + linear_[l] * cs];
        }
      }
    };
    for (int64_t t = col_start[i]; t < col_start[i + 1]; ++t) {
      add_block(col_rows[t], s.StoredBlock(col_blocks[t]), 1, b);
    }
    for (int64_t j = row_start[i]; j < row_start[i + 1]; ++j) {
      add_block(cols[j], s.StoredBlock(j), b, 1);
    }
    sw_row_start_[i + 1] = static_cast<int64_t>(sw_cols_.size());
  }

  // E = W^T (S W): block (a(i), a) += W_i^T SW(i,a) (wb x wb).
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < nb; ++i) {
    for (int64_t j = sw_row_start_[i]; j < sw_row_start_[i + 1]; ++j) {
      if (aggregate_[i] < sw_cols_[j]) pairs.emplace_back(aggregate_[i], sw_cols_[j]);
    }
  }
  BlockSparseMatrix e = BlockSparseMatrix::FromPattern(wb, na, std::move(pairs));
  // E stores its upper triangle only; the blocks (a(i), a) with a(i) > a
  // are the lower ones (equal to the upper ones in exact arithmetic) and are
  // skipped. CHOLMOD reads only the upper triangle (ToSparseUpper) anyway.
  for (int i = 0; i < nb; ++i) {
    for (int64_t j = sw_row_start_[i]; j < sw_row_start_[i + 1]; ++j) {
      if (aggregate_[i] > sw_cols_[j]) continue;
      double* out = e.MutableBlock(aggregate_[i], sw_cols_[j]);
      GS_CHECK(out != nullptr);
      const double* sw = sw_values_.data() + j * b * wb;
      for (int r = 0; r < b; ++r) {
        for (int c = 0; c < wb; ++c) out[r * wb + c] += sw[r * wb + c];
      }
      for (int l = 0; l < num_linear; ++l) {
        for (int c = 0; c < wb; ++c) out[(b + l) * wb + c] += t_[i] * sw[linear_[l] * wb + c];
      }
    }
  }
  const Status factored = coarse_.Factorize(e);
  if (!factored.ok()) {
    num_aggregates_ = 0;
    return Status::Numerical(fmt::format(
        "trajectory deflation: the coarse matrix W^T S W ({} unknowns) does not factor, so S "
        "is not positive definite: {}",
        na * wb, factored.message()));
  }
  num_aggregates_ = na;
  coarse_rhs_.resize(static_cast<Eigen::Index>(na) * wb);
  return Status::Ok();
}

void TrajectoryDeflation::RestrictTo(const double* v, Eigen::VectorXd* out) const {
  const int b = block_size_;
  const int wb = width_;
  out->setZero(static_cast<Eigen::Index>(num_aggregates_) * wb);
  for (int i = 0; i < num_blocks_; ++i) {
    double* o = out->data() + static_cast<int64_t>(aggregate_[i]) * wb;
    const double* vi = v + static_cast<int64_t>(i) * b;
    for (int r = 0; r < b; ++r) o[r] += vi[r];
    for (size_t l = 0; l < linear_.size(); ++l) o[b + l] += t_[i] * vi[linear_[l]];
  }
}

void TrajectoryDeflation::Prolong(const Eigen::VectorXd& c, double sign, double* y) const {
  const int b = block_size_;
  for (int i = 0; i < num_blocks_; ++i) {
    const double* ci = c.data() + static_cast<int64_t>(aggregate_[i]) * width_;
    double* yi = y + static_cast<int64_t>(i) * b;
    for (int r = 0; r < b; ++r) yi[r] += sign * ci[r];
    for (size_t l = 0; l < linear_.size(); ++l) yi[linear_[l]] += sign * t_[i] * ci[b + l];
  }
}

void TrajectoryDeflation::RightMultiplyAndAccumulate(const double* x, double* y) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const int n = num_rows_;
  std::fill(inner_result_.begin(), inner_result_.end(), 0.0);
  inner_->RightMultiplyAndAccumulate(x, inner_result_.data());
  for (int j = 0; j < n; ++j) y[j] += inner_result_[j];
  if (num_aggregates_ == 0) return;
  // coarse_rhs = (S W)^T z.
  const int b = block_size_, wb = width_;
  coarse_rhs_.setZero();
  for (int i = 0; i < num_blocks_; ++i) {
    const double* zi = inner_result_.data() + static_cast<int64_t>(i) * b;
    for (int64_t j = sw_row_start_[i]; j < sw_row_start_[i + 1]; ++j) {
      const double* sw = sw_values_.data() + j * b * wb;
      double* o = coarse_rhs_.data() + static_cast<int64_t>(sw_cols_[j]) * wb;
      for (int r = 0; r < b; ++r) {
        for (int c = 0; c < wb; ++c) o[c] += sw[r * wb + c] * zi[r];
      }
    }
  }
  const Status solved = coarse_.Solve(coarse_rhs_, &coarse_x_);
  GS_CHECK(solved.ok());  // E was factored by Update; the sizes are ours
  Prolong(coarse_x_, -1.0, y);
}

Status TrajectoryDeflation::CoarseCorrect(const BlockSparseMatrix& s, const Eigen::VectorXd& b,
                                          Eigen::VectorXd* x) const {
  if (num_aggregates_ == 0) return Status::Ok();
  GS_CHECK(s.num_rows() == num_rows_ && b.size() == num_rows_ && x->size() == num_rows_);
  Eigen::VectorXd r = b;
  Eigen::VectorXd sx = Eigen::VectorXd::Zero(num_rows_);
  s.RightMultiplyAndAccumulate(x->data(), sx.data());
  r -= sx;
  Eigen::VectorXd coarse_rhs, coarse_x;
  RestrictTo(r.data(), &coarse_rhs);
  std::lock_guard<std::mutex> lock(mutex_);  // CHOLMOD's workspace
  GS_RETURN_IF_ERROR(coarse_.Solve(coarse_rhs, &coarse_x));
  Prolong(coarse_x, 1.0, x->data());
  return Status::Ok();
}

}  // namespace graphslam::core
