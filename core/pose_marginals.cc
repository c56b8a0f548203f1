#include "core/pose_marginals.h"

#include <cholmod.h>

#include <algorithm>
#include <string>

#include "core/check.h"

namespace graphslam::core {

// CHOLMOD's own API (not Eigen's wrapper): the ordering is chosen here
// (METIS nested dissection, see the header) and the factor is read directly.
struct PoseMarginals::Impl {
  cholmod_common common;
  cholmod_factor* factor = nullptr;  // simplicial LL^T, packed, after Factorize
  int num_rows = 0;
  int block_size = 0;
  bool factorized = false;
  std::vector<int32_t> parent;           // elimination tree (-1: root)
  std::vector<int32_t> inverse_permutation;  // original row -> position

  Impl() {
    cholmod_start(&common);
    common.print = 0;
  }
  ~Impl() {
    if (factor != nullptr) cholmod_free_factor(&factor, &common);
    cholmod_finish(&common);
  }
};

PoseMarginals::PoseMarginals() : impl_(std::make_unique<Impl>()) {}
PoseMarginals::~PoseMarginals() = default;

int PoseMarginals::num_rows() const { return impl_->num_rows; }
int PoseMarginals::block_size() const { return impl_->block_size; }

Status PoseMarginals::Factorize(const BlockSparseMatrix& s) {
  Impl& impl = *impl_;
  impl.factorized = false;
  if (impl.factor != nullptr) cholmod_free_factor(&impl.factor, &impl.common);
  impl.num_rows = s.num_rows();
  impl.block_size = s.block_size();
  impl.parent.clear();
  impl.inverse_permutation.clear();
  if (s.num_rows() == 0) {
    impl.factorized = true;
    return Status::Ok();
  }
  Eigen::SparseMatrix<double> upper = s.ToSparseUpper();
  upper.makeCompressed();
  cholmod_sparse a{};
  a.nrow = a.ncol = static_cast<size_t>(upper.rows());
  a.nzmax = static_cast<size_t>(upper.nonZeros());
  a.p = upper.outerIndexPtr();
  a.i = upper.innerIndexPtr();
  a.x = upper.valuePtr();
  a.stype = 1;  // upper triangle stored
  a.itype = CHOLMOD_INT;
  a.xtype = CHOLMOD_REAL;
  a.dtype = CHOLMOD_DOUBLE;
  a.sorted = 1;
  a.packed = 1;

  // METIS nested dissection for a shallow elimination tree; AMD if this
  // CHOLMOD was built without METIS.
  impl.common.nmethods = 1;
  impl.common.method[0].ordering = CHOLMOD_METIS;
  impl.common.postorder = 1;
  impl.factor = cholmod_analyze(&a, &impl.common);
  if (impl.factor == nullptr || impl.common.status != CHOLMOD_OK) {
    if (impl.factor != nullptr) cholmod_free_factor(&impl.factor, &impl.common);
    impl.common.method[0].ordering = CHOLMOD_AMD;
    impl.factor = cholmod_analyze(&a, &impl.common);
  }
  if (impl.factor == nullptr) {
    return Status::Numerical("pose marginals: CHOLMOD analysis of the reduced information "
                             "matrix (" + std::to_string(s.num_rows()) + " rows) failed");
  }
  const int ok = cholmod_factorize(&a, impl.factor, &impl.common);
  if (!ok || impl.common.status != CHOLMOD_OK || impl.factor->minor < impl.factor->n) {
    return Status::Numerical("pose marginals: reduced information matrix (" +
                             std::to_string(s.num_rows()) +
                             " rows) is not positive definite (CHOLMOD); expected a "
                             "converged, well-constrained solve");
  }
  // Simplicial, packed, LL^T: columns read directly by Whiten (diagonal first).
  if (!cholmod_change_factor(CHOLMOD_REAL, /*to_ll=*/1, /*to_super=*/0, /*to_packed=*/1,
                             /*to_monotonic=*/1, impl.factor, &impl.common)) {
    return Status::Numerical("pose marginals: CHOLMOD could not convert the factor");
  }
  const cholmod_factor& l = *impl.factor;
  const int n = static_cast<int>(l.n);
  const int* lp = static_cast<const int*>(l.p);
  const int* li = static_cast<const int*>(l.i);
  const int* perm = static_cast<const int*>(l.Perm);
  impl.parent.assign(n, -1);
  impl.inverse_permutation.assign(n, 0);
  for (int k = 0; k < n; ++k) {
    GS_CHECK(li[lp[k]] == k);  // CHOLMOD keeps the diagonal first
    int first = n;
    for (int t = lp[k] + 1; t < lp[k + 1]; ++t) first = std::min(first, li[t]);
    impl.parent[k] = first < n ? first : -1;
    impl.inverse_permutation[perm[k]] = k;
  }
  impl.factorized = true;
  return Status::Ok();
}

double PoseMarginals::MeanReach() const {
  const std::vector<int32_t>& parent = impl_->parent;
  const int n = static_cast<int>(parent.size());
  if (n == 0) return 0.0;
  std::vector<int32_t> depth(n, 1);
  double sum = 0.0;
  for (int k = n - 1; k >= 0; --k) {  // parent[k] > k
    if (parent[k] >= 0) depth[k] = depth[parent[k]] + 1;
    sum += depth[k];
  }
  return sum / n;
}

Status PoseMarginals::ForEachColumnBlock(
    const std::vector<int>& blocks, int batch,
    const std::function<void(int, const Eigen::Ref<const Eigen::MatrixXd>&)>& visit) const {
  if (!impl_->factorized) {
    return Status::InvalidArgument("pose marginals: ForEachColumnBlock before Factorize");
  }
  const int n = impl_->num_rows;
  const int b = impl_->block_size;
  batch = std::max(1, batch);
  for (int block : blocks) {
    if (block < 0 || (block + 1) * b > n) {
      return Status::InvalidArgument("pose marginals: block " + std::to_string(block) +
                                     " is outside the " + std::to_string(n / std::max(b, 1)) +
                                     " blocks of the reduced system");
    }
  }
  Eigen::MatrixXd rhs;
  for (size_t begin = 0; begin < blocks.size(); begin += batch) {
    const size_t end = std::min(blocks.size(), begin + static_cast<size_t>(batch));
    const int k = static_cast<int>(end - begin);
    rhs.setZero(n, k * b);
    for (int i = 0; i < k; ++i)
      rhs.block(static_cast<Eigen::Index>(blocks[begin + i]) * b, i * b, b, b).setIdentity();
    cholmod_dense dense{};
    dense.nrow = static_cast<size_t>(n);
    dense.ncol = static_cast<size_t>(k * b);
    dense.nzmax = dense.nrow * dense.ncol;
    dense.d = dense.nrow;
    dense.x = rhs.data();
    dense.xtype = CHOLMOD_REAL;
    dense.dtype = CHOLMOD_DOUBLE;
    cholmod_dense* solved = cholmod_solve(CHOLMOD_A, impl_->factor, &dense, &impl_->common);
    if (solved == nullptr) {
      return Status::Numerical("pose marginals: CHOLMOD solve failed");
    }
    const Eigen::Map<const Eigen::MatrixXd> solution(static_cast<const double*>(solved->x), n,
                                                     k * b);
    const bool finite = solution.allFinite();
    if (finite)
      for (int i = 0; i < k; ++i) visit(blocks[begin + i], solution.middleCols(i * b, b));
    cholmod_free_dense(&solved, &impl_->common);
    if (!finite) {
      return Status::Numerical("pose marginals: CHOLMOD solve gave non-finite covariance "
                               "columns");
    }
  }
  return Status::Ok();
}

Status PoseMarginals::Whiten(const std::vector<int32_t>& blocks,
                             const std::vector<Eigen::Matrix<double, 3, 2>>& values,
                             WhitenedColumns* out, WhitenWorkspace* workspace) const {
  const Impl& impl = *impl_;
  if (!impl.factorized) return Status::InvalidArgument("pose marginals: Whiten before Factorize");
  if (impl.block_size != 3 && impl.num_rows > 0)
    return Status::InvalidArgument("pose marginals: Whiten needs 3 x 3 blocks, the system has " +
                                   std::to_string(impl.block_size));
  if (blocks.size() != values.size())
    return Status::InvalidArgument("pose marginals: Whiten got " + std::to_string(blocks.size()) +
                                   " blocks and " + std::to_string(values.size()) + " values");
  const int n = impl.num_rows;
  for (int32_t block : blocks) {
    if (block < 0 || 3 * (block + 1) > n)
      return Status::InvalidArgument("pose marginals: block " + std::to_string(block) +
                                     " is outside the " + std::to_string(n / 3) +
                                     " blocks of the reduced system");
  }
  WhitenWorkspace& w = *workspace;
  if (static_cast<int>(w.mark.size()) != n) {
    w.mark.assign(n, 0);
    w.x.assign(2 * static_cast<size_t>(n), 0.0);
    w.stamp = 0;
  }
  if (++w.stamp == 0) {  // wrapped: clear the marks
    std::fill(w.mark.begin(), w.mark.end(), 0);
    w.stamp = 1;
  }
  // The reach: every row on the elimination-tree path from B's rows to the root.
  std::vector<int32_t>& reach = out->rows;
  reach.clear();
  for (int32_t block : blocks) {
    for (int r = 0; r < 3; ++r) {
      for (int32_t k = impl.inverse_permutation[3 * block + r]; k >= 0 && w.mark[k] != w.stamp;
           k = impl.parent[k]) {
        w.mark[k] = w.stamp;
        reach.push_back(k);
      }
    }
  }
  std::sort(reach.begin(), reach.end());  // children before parents
  for (int32_t k : reach) w.x[2 * k] = w.x[2 * k + 1] = 0.0;
  for (size_t i = 0; i < blocks.size(); ++i) {
    for (int r = 0; r < 3; ++r) {
      const int32_t k = impl.inverse_permutation[3 * blocks[i] + r];
      w.x[2 * k] += values[i](r, 0);
      w.x[2 * k + 1] += values[i](r, 1);
    }
  }
  // Column-oriented forward solve L y = P B over the reach only.
  const cholmod_factor& l = *impl.factor;
  const int* lp = static_cast<const int*>(l.p);
  const int* li = static_cast<const int*>(l.i);
  const double* lx = static_cast<const double*>(l.x);
  for (int32_t k : reach) {
    const double d = lx[lp[k]];
    const double y0 = w.x[2 * k] /= d;
    const double y1 = w.x[2 * k + 1] /= d;
    if (y0 == 0.0 && y1 == 0.0) continue;
    for (int t = lp[k] + 1; t < lp[k + 1]; ++t) {
      const double v = lx[t];
      double* xi = &w.x[2 * li[t]];
      xi[0] -= v * y0;
      xi[1] -= v * y1;
    }
  }
  out->values.resize(2 * reach.size());
  for (size_t i = 0; i < reach.size(); ++i) {
    out->values[2 * i] = w.x[2 * reach[i]];
    out->values[2 * i + 1] = w.x[2 * reach[i] + 1];
  }
  return Status::Ok();
}

Eigen::Matrix2d PoseMarginals::Dot(const WhitenedColumns& a, const WhitenedColumns& b) {
  double s00 = 0.0, s01 = 0.0, s10 = 0.0, s11 = 0.0;
  size_t i = 0, j = 0;
  const size_t na = a.rows.size(), nb = b.rows.size();
  while (i < na && j < nb) {
    const int32_t ra = a.rows[i], rb = b.rows[j];
    if (ra < rb) {
      ++i;
    } else if (rb < ra) {
      ++j;
    } else {
      const double a0 = a.values[2 * i], a1 = a.values[2 * i + 1];
      const double b0 = b.values[2 * j], b1 = b.values[2 * j + 1];
      s00 += a0 * b0;
      s01 += a0 * b1;
      s10 += a1 * b0;
      s11 += a1 * b1;
      ++i;
      ++j;
    }
  }
  Eigen::Matrix2d out;
  out << s00, s01, s10, s11;
  return out;
}

}  // namespace graphslam::core
