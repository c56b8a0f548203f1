#include "core/cholmod_solver.h"

#include <Eigen/CholmodSupport>
#include <fmt/format.h>
#include <omp.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "core/check.h"
#include "core/logging.h"

namespace graphslam::core {
namespace {

using SparseUpper = Eigen::SparseMatrix<double>;

// Exposes CHOLMOD's factor, which Eigen keeps protected, to report where a
// factorization failed (cholmod_factor::minor) and to detect a failed analysis.
class SupernodalLlt : public Eigen::CholmodSupernodalLLT<SparseUpper, Eigen::Upper> {
 public:
  const cholmod_factor* factor() const { return m_cholmodFactor; }
};

// Makes CHOLMOD's OpenMP regions run on the calling thread alone while it
// lives. Debian's CHOLMOD opens them in the supernodal factorization with a
// fixed num_threads(4) clause, which OMP_NUM_THREADS cannot lower; they only
// clear and scatter memory, and on 2 cores beside TBB's threads, waking four
// OpenMP threads per supernode and spinning them afterwards costs more than
// it saves (docs/benchmarks.md, "Where the time goes").
// max-active-levels 0 makes every region inactive; the caller's value comes
// back on exit. Our own parallelism is TBB's.
class SerialOpenMpRegions {
 public:
  SerialOpenMpRegions() : saved_(omp_get_max_active_levels()) { omp_set_max_active_levels(0); }
  ~SerialOpenMpRegions() { omp_set_max_active_levels(saved_); }
  SerialOpenMpRegions(const SerialOpenMpRegions&) = delete;
  SerialOpenMpRegions& operator=(const SerialOpenMpRegions&) = delete;

 private:
  int saved_;
};

}  // namespace

struct CholmodSolver::Impl {
  SupernodalLlt llt;
  bool analyzed = false;
  bool factorized = false;
  int num_analyses = 0;
  int block_size = 0;
  int num_rows = 0;
  // The analyzed pattern, compared exactly on every Factorize.
  std::vector<int> outer;
  std::vector<int> inner;

  bool SamePattern(const SparseUpper& m) const {
    if (!analyzed || m.rows() != num_rows) return false;
    if (static_cast<size_t>(m.nonZeros()) != inner.size()) return false;
    return std::equal(outer.begin(), outer.end(), m.outerIndexPtr()) &&
           std::equal(inner.begin(), inner.end(), m.innerIndexPtr());
  }
};

CholmodSolver::CholmodSolver() : impl_(std::make_unique<Impl>()) {
  cholmod_common& common = impl_->llt.cholmod();
  common.print = 0;  // libraries never print; errors come back as Status
}

CholmodSolver::~CholmodSolver() = default;

int CholmodSolver::num_analyses() const { return impl_->num_analyses; }
bool CholmodSolver::factorized() const { return impl_->factorized; }
int CholmodSolver::num_rows() const { return impl_->num_rows; }

Status CholmodSolver::Factorize(const BlockSparseMatrix& a) {
  Impl& impl = *impl_;
  impl.factorized = false;
  impl.block_size = a.block_size();
  if (a.num_rows() == 0) {  // nothing to factorize; CHOLMOD is not called
    impl.num_rows = 0;
    impl.analyzed = false;
    impl.factorized = true;
    return Status::Ok();
  }
  const SparseUpper upper = a.ToSparseUpper();
  const SerialOpenMpRegions serial_openmp;
  if (!impl.SamePattern(upper)) {
    impl.analyzed = false;
    impl.llt.analyzePattern(upper);
    ++impl.num_analyses;
    if (impl.llt.factor() == nullptr) {
      return Status::Numerical(fmt::format(
          "CHOLMOD symbolic analysis of the reduced information matrix ({} rows, {} nonzeros "
          "in the upper triangle) failed: CHOLMOD status {}",
          upper.rows(), upper.nonZeros(), impl.llt.cholmod().status));
    }
    impl.outer.assign(upper.outerIndexPtr(), upper.outerIndexPtr() + upper.outerSize() + 1);
    impl.inner.assign(upper.innerIndexPtr(), upper.innerIndexPtr() + upper.nonZeros());
    impl.num_rows = static_cast<int>(upper.rows());
    impl.analyzed = true;
    // The factor's size and cost (what --solver auto compares; it does not
    // analyse above its unknowns budget, so -v gives them here too).
    GS_VLOG(1, "CHOLMOD analysis: %lld rows, %lld nonzeros in the upper triangle, factor %.3g "
            "nonzeros (lnz), %.3g flops (fl)", static_cast<long long>(upper.rows()),
            static_cast<long long>(upper.nonZeros()), impl.llt.cholmod().lnz,
            impl.llt.cholmod().fl);
  }
  impl.llt.factorize(upper);
  const cholmod_factor* factor = impl.llt.factor();
  const int status = impl.llt.cholmod().status;
  if (impl.llt.info() != Eigen::Success || status == CHOLMOD_NOT_POSDEF) {
    // minor is the first column (in the permuted order) where the
    // factorization failed; Perm maps it back to a row of S.
    long column = static_cast<long>(factor->minor);
    if (factor->Perm != nullptr && column < static_cast<long>(factor->n)) {
      column = static_cast<const int*>(factor->Perm)[column];
    }
    return Status::Numerical(fmt::format(
        "reduced information matrix is not positive definite (CHOLMOD): factorization failed "
        "at row {} (block row {}) of {}",
        column, column / std::max(1, impl.block_size), impl.num_rows));
  }
  if (status < CHOLMOD_OK) {
    return Status::Numerical(fmt::format(
        "CHOLMOD factorization of the reduced information matrix failed: CHOLMOD status {}",
        status));
  }
  impl.factorized = true;
  return Status::Ok();
}

Status CholmodSolver::Solve(const Eigen::VectorXd& b, Eigen::VectorXd* x) const {
  GS_CHECK(impl_->factorized);
  if (b.size() != impl_->num_rows) {
    return Status::InvalidArgument(fmt::format(
        "CholmodSolver::Solve: right-hand side has {} rows, the factorized matrix {}", b.size(),
        impl_->num_rows));
  }
  if (impl_->num_rows == 0) {
    x->resize(0);
    return Status::Ok();
  }
  Eigen::VectorXd solution = impl_->llt.solve(b);
  if (impl_->llt.info() != Eigen::Success) {
    return Status::Numerical(fmt::format(
        "CHOLMOD solve with the reduced information matrix failed: CHOLMOD status {}",
        impl_->llt.cholmod().status));
  }
  if (!solution.allFinite()) {
    return Status::Numerical("CHOLMOD solve with the reduced information matrix produced "
                             "non-finite values");
  }
  *x = std::move(solution);
  return Status::Ok();
}

}  // namespace graphslam::core
