#include "core/pose_marginals.h"

#include <Eigen/CholmodSupport>

#include <algorithm>
#include <string>

namespace graphslam::core {

struct PoseMarginals::Impl {
  Eigen::CholmodSupernodalLLT<Eigen::SparseMatrix<double>, Eigen::Upper> llt;
  int num_rows = 0;
  int block_size = 0;
  bool factorized = false;
};

PoseMarginals::PoseMarginals() : impl_(std::make_unique<Impl>()) {}
PoseMarginals::~PoseMarginals() = default;

int PoseMarginals::num_rows() const { return impl_->num_rows; }
int PoseMarginals::block_size() const { return impl_->block_size; }

Status PoseMarginals::Factorize(const BlockSparseMatrix& s) {
  impl_->factorized = false;
  impl_->num_rows = s.num_rows();
  impl_->block_size = s.block_size();
  if (s.num_rows() == 0) {
    impl_->factorized = true;
    return Status::Ok();
  }
  const Eigen::SparseMatrix<double> upper = s.ToSparseUpper();
  impl_->llt.cholmod().print = 0;
  impl_->llt.compute(upper);
  if (impl_->llt.info() != Eigen::Success) {
    return Status::Numerical("pose marginals: reduced information matrix (" +
                             std::to_string(s.num_rows()) +
                             " rows) is not positive definite (CHOLMOD); expected a "
                             "converged, well-constrained solve");
  }
  impl_->factorized = true;
  return Status::Ok();
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
  Eigen::MatrixXd solution;
  for (size_t begin = 0; begin < blocks.size(); begin += batch) {
    const size_t end = std::min(blocks.size(), begin + static_cast<size_t>(batch));
    const int k = static_cast<int>(end - begin);
    rhs.setZero(n, k * b);
    for (int i = 0; i < k; ++i)
      rhs.block(static_cast<Eigen::Index>(blocks[begin + i]) * b, i * b, b, b).setIdentity();
    solution = impl_->llt.solve(rhs);
    if (impl_->llt.info() != Eigen::Success || !solution.allFinite()) {
      return Status::Numerical("pose marginals: CHOLMOD solve failed or gave non-finite "
                               "covariance columns");
    }
    for (int i = 0; i < k; ++i) visit(blocks[begin + i], solution.middleCols(i * b, b));
  }
  return Status::Ok();
}

}  // namespace graphslam::core
