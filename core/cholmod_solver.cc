#include "core/cholmod_solver.h"

#include <cholmod.h>
#include <fmt/format.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "core/check.h"
#include "core/logging.h"
#include "core/serial_openmp.h"

namespace graphslam::core {
namespace {

// Supernodal when the factor has at least this many flops per nonzero
// (CHOLMOD's automatic choice uses 40). Per factorization, CPU time,
// simplicial / supernodal, with the OpenMP regions inline
// (core/serial_openmp.h): a 10 000-pose chain with 300 short loops (8 flops
// per nonzero) 5.4 / 6.7 ms, M3500 (35) 5.5 / 4.2 ms, intel (58) 5.2 / 2.9 ms.
constexpr double kSupernodalSwitch = 20.0;

// cholmod_start / cholmod_finish around a common object; printing off.
class Common {
 public:
  Common() {
    cholmod_start(&common_);
    common_.print = 0;  // libraries never print; errors come back as Status
  }
  ~Common() { cholmod_finish(&common_); }
  Common(const Common&) = delete;
  Common& operator=(const Common&) = delete;
  cholmod_common* get() { return &common_; }

 private:
  cholmod_common common_;
};

// The scalar upper triangle of a block pattern, compressed by columns with
// sorted rows, and for every entry its index in the stored values
// (BlockSparseMatrix::StoredBlock(0)[source]). Column k*b + c holds the
// strictly-upper blocks (i < k, k) of block column k (transpose index, rows
// ascending), then rows k*b .. k*b + c of the diagonal block.
struct UpperPattern {
  std::vector<int> col_start;
  std::vector<int> rows;
  std::vector<int64_t> source;
};

UpperPattern MakeUpperPattern(const BlockSparseMatrix& a) {
  const int b = a.block_size();
  const int64_t bb = static_cast<int64_t>(b) * b;
  const int n = a.num_rows();
  const int64_t strict = static_cast<int64_t>(a.col_rows().size());
  const int64_t nnz = strict * bb + static_cast<int64_t>(a.num_block_rows()) * b * (b + 1) / 2;
  GS_CHECK(nnz < int64_t{1} << 31);
  UpperPattern u;
  u.col_start.reserve(static_cast<size_t>(n) + 1);
  u.rows.reserve(static_cast<size_t>(nnz));
  u.source.reserve(static_cast<size_t>(nnz));
  u.col_start.push_back(0);
  for (int k = 0; k < a.num_block_rows(); ++k) {
    for (int c = 0; c < b; ++c) {
      for (int64_t t = a.col_start()[k]; t < a.col_start()[k + 1]; ++t) {
        const int i = a.col_rows()[t];
        const int64_t j = a.col_blocks()[t];
        for (int r = 0; r < b; ++r) {
          u.rows.push_back(i * b + r);
          u.source.push_back(j * bb + r * b + c);
        }
      }
      const int64_t j = a.row_start()[k];
      for (int r = 0; r <= c; ++r) {
        u.rows.push_back(k * b + r);
        u.source.push_back(j * bb + r * b + c);
      }
      u.col_start.push_back(static_cast<int>(u.rows.size()));
    }
  }
  return u;
}

// A CHOLMOD view of a pattern-only symmetric matrix (upper triangle stored).
// (n columns of col_start / rows, which must outlive the view.)
cholmod_sparse PatternView(int n, std::vector<int>* col_start, std::vector<int>* rows) {
  cholmod_sparse view{};
  view.nrow = view.ncol = static_cast<size_t>(n);
  view.nzmax = rows->size();
  view.p = col_start->data();
  view.i = rows->data();
  view.stype = 1;
  view.itype = CHOLMOD_INT;
  view.xtype = CHOLMOD_PATTERN;
  view.dtype = CHOLMOD_DOUBLE;
  view.sorted = 1;
  view.packed = 1;
  return view;
}

}  // namespace

bool CholmodOrdering::Orders(const BlockSparseMatrix& a) const {
  return a.block_size() == block_size && a.row_start() == row_start &&
         a.block_cols() == block_cols;
}

namespace {

// The block pattern's upper triangle (diagonal included), compressed by
// columns with sorted rows: one node per pose block.
struct BlockUpperPattern {
  std::vector<int> col_start;
  std::vector<int> rows;
};

BlockUpperPattern MakeBlockUpperPattern(const BlockSparseMatrix& a) {
  BlockUpperPattern u;
  const int nb = a.num_block_rows();
  GS_CHECK(static_cast<int64_t>(a.col_rows().size()) + nb < int64_t{1} << 31);
  u.col_start.reserve(static_cast<size_t>(nb) + 1);
  u.rows.reserve(a.col_rows().size() + static_cast<size_t>(nb));
  u.col_start.push_back(0);
  for (int k = 0; k < nb; ++k) {
    for (int64_t t = a.col_start()[k]; t < a.col_start()[k + 1]; ++t)
      u.rows.push_back(a.col_rows()[t]);
    u.rows.push_back(k);
    u.col_start.push_back(static_cast<int>(u.rows.size()));
  }
  return u;
}

// CHOLMOD's default strategy also tries METIS when AMD's factor is large and
// dense (cholmod_analyze: fl >= 500 lnz and lnz >= 5 nnz(A)).
bool DefaultStrategyTriesMetis(double flops, double factor_nonzeros, double matrix_nonzeros) {
  return flops >= 500.0 * factor_nonzeros && factor_nonzeros >= 5.0 * matrix_nonzeros;
}

StatusOr<std::shared_ptr<const CholmodOrdering>> AnalyzeScalarOrdering(
    const BlockSparseMatrix& a) {
  UpperPattern upper = MakeUpperPattern(a);
  cholmod_sparse view = PatternView(a.num_rows(), &upper.col_start, &upper.rows);
  Common common;
  // Only the ordering and its counts are wanted here; the supernodes are
  // found when the solver analyses the permuted matrix.
  common.get()->supernodal = CHOLMOD_SIMPLICIAL;
  cholmod_factor* factor = cholmod_analyze(&view, common.get());
  if (factor == nullptr || common.get()->status < CHOLMOD_OK || !(common.get()->lnz > 0)) {
    if (factor != nullptr) cholmod_free_factor(&factor, common.get());
    return Status::Numerical(fmt::format(
        "CHOLMOD symbolic analysis of the reduced information matrix ({} rows, {} nonzeros "
        "in the upper triangle) failed: CHOLMOD status {}",
        a.num_rows(), upper.rows.size(), common.get()->status));
  }
  auto ordering = std::make_shared<CholmodOrdering>();
  const int* perm = static_cast<const int*>(factor->Perm);
  ordering->permutation.assign(perm, perm + a.num_rows());
  ordering->factor_nonzeros = common.get()->lnz;
  ordering->factor_flops = common.get()->fl;
  ordering->block_size = a.block_size();
  ordering->row_start = a.row_start();
  ordering->block_cols = a.block_cols();
  cholmod_free_factor(&factor, common.get());
  return std::shared_ptr<const CholmodOrdering>(std::move(ordering));
}

}  // namespace

StatusOr<std::shared_ptr<const CholmodOrdering>> AnalyzeCholmodOrdering(
    const BlockSparseMatrix& a) {
  GS_CHECK(a.num_rows() > 0);
  const int b = a.block_size();
  const int nb = a.num_block_rows();
  BlockUpperPattern blocks = MakeBlockUpperPattern(a);
  cholmod_sparse view = PatternView(nb, &blocks.col_start, &blocks.rows);
  Common common;
  cholmod_common* c = common.get();
  c->nmethods = 1;
  c->method[0].ordering = CHOLMOD_AMD;
  c->supernodal = CHOLMOD_SIMPLICIAL;
  cholmod_factor* factor = cholmod_analyze(&view, c);
  if (factor == nullptr || c->status < CHOLMOD_OK || !(c->lnz > 0)) {
    if (factor != nullptr) cholmod_free_factor(&factor, c);
    return Status::Numerical(fmt::format(
        "CHOLMOD symbolic analysis of the reduced information matrix's block pattern ({} "
        "block rows, {} blocks in the upper triangle) failed: CHOLMOD status {}",
        nb, blocks.rows.size(), c->status));
  }
  // Every block of the pattern is stored dense, so the scalar factor of the
  // expanded ordering is the block factor with dense blocks: block column k
  // with m blocks (its diagonal one included) gives scalar columns of
  // (m - 1) b + b - r nonzeros, r = 0 .. b-1. lnz and fl as CHOLMOD counts
  // them (fl = sum of squared column counts).
  auto ordering = std::make_shared<CholmodOrdering>();
  const int* block_perm = static_cast<const int*>(factor->Perm);
  const int* block_counts = static_cast<const int*>(factor->ColCount);
  ordering->permutation.resize(static_cast<size_t>(a.num_rows()));
  double lnz = 0.0, flops = 0.0;
  for (int k = 0; k < nb; ++k) {
    for (int r = 0; r < b; ++r) {
      ordering->permutation[static_cast<size_t>(k) * b + r] = block_perm[k] * b + r;
      const double count = static_cast<double>(block_counts[k] - 1) * b + (b - r);
      lnz += count;
      flops += count * count;
    }
  }
  cholmod_free_factor(&factor, c);
  const double matrix_nonzeros = static_cast<double>(blocks.rows.size() - nb) * b * b +
                                 static_cast<double>(nb) * b * (b + 1) / 2;
  // Where CHOLMOD's default would weigh METIS against AMD, it runs on the
  // scalar pattern as before (large dense factors, where the ordering's cost
  // is small beside the factorization's).
  if (DefaultStrategyTriesMetis(flops, lnz, matrix_nonzeros)) return AnalyzeScalarOrdering(a);
  ordering->factor_nonzeros = lnz;
  ordering->factor_flops = flops;
  ordering->block_size = b;
  ordering->row_start = a.row_start();
  ordering->block_cols = a.block_cols();
  return std::shared_ptr<const CholmodOrdering>(std::move(ordering));
}

namespace {

// B = P S P^T for any permutation: entry (p, q) of S's upper triangle goes
// to (inverse[p], inverse[q]), stored in the lower triangle (supernodal) or
// the upper one (simplicial), rows sorted within each column; bp, bi and
// gather as in BlockLowerPattern.
void ScalarPattern(const BlockSparseMatrix& a, const std::vector<int>& permutation,
                   bool supernodal, int* bp, int* bi, int64_t* gather) {
  const int n = a.num_rows();
  UpperPattern upper = MakeUpperPattern(a);
  std::vector<int> inverse(static_cast<size_t>(n));
  for (int k = 0; k < n; ++k) inverse[permutation[k]] = k;
  const size_t nnz = upper.rows.size();
  std::vector<int> col_start(static_cast<size_t>(n) + 1, 0);
  auto place = [&](int p, int q) {
    const int pp = inverse[p], qq = inverse[q];
    return supernodal ? std::make_pair(std::max(pp, qq), std::min(pp, qq))
                      : std::make_pair(std::min(pp, qq), std::max(pp, qq));
  };  // (row, column)
  for (int q = 0; q < n; ++q) {
    for (int e = upper.col_start[q]; e < upper.col_start[q + 1]; ++e)
      ++col_start[place(upper.rows[e], q).second + 1];
  }
  for (int q = 0; q < n; ++q) col_start[q + 1] += col_start[q];
  std::vector<std::pair<int, int64_t>> entries(nnz);  // (row, source)
  {
    std::vector<int> next(col_start.begin(), col_start.end() - 1);
    for (int q = 0; q < n; ++q) {
      for (int e = upper.col_start[q]; e < upper.col_start[q + 1]; ++e) {
        const auto [row, col] = place(upper.rows[e], q);
        entries[next[col]++] = {row, upper.source[e]};
      }
    }
  }
  for (int q = 0; q < n; ++q) {
    bp[q] = col_start[q];
    std::sort(entries.begin() + col_start[q], entries.begin() + col_start[q + 1]);
    for (int m = col_start[q]; m < col_start[q + 1]; ++m) {
      bi[m] = entries[m].first;
      gather[m] = entries[m].second;
    }
  }
  bp[n] = col_start[n];
}

// block_of[K] = k when `permutation` moves whole blocks of size b (entry
// K*b + r is k*b + r), as the block ordering of AnalyzeCholmodOrdering does;
// false for a scalar ordering.
bool BlockPermutation(const std::vector<int>& permutation, int b, std::vector<int>* block_of) {
  const size_t nb = permutation.size() / static_cast<size_t>(b);
  block_of->resize(nb);
  for (size_t k = 0; k < nb; ++k) {
    const int first = permutation[k * b];
    if (first % b != 0) return false;
    for (int r = 1; r < b; ++r) {
      if (permutation[k * b + r] != first + r) return false;
    }
    (*block_of)[k] = first / b;
  }
  return true;
}

// The lower triangle of B = P S P^T for a block permutation (block_of), in
// CHOLMOD's compressed columns with sorted rows: bp (n + 1), bi and, for
// every entry, its index in S's stored values (gather). Built block by
// block: a block column's blocks are sorted by block row, then expanded
// (the same pattern and values as the scalar construction in Analyze, with
// b^2 fewer entries to sort). B's block (R, C), R >= C, is S's block
// (k_R, k_C); S stores the upper one, (k_R, k_C) or its transpose, and of
// a diagonal block the upper entries, as B's scalar construction reads them.
void BlockLowerPattern(const BlockSparseMatrix& a, const std::vector<int>& block_of, int* bp,
                       int* bi, int64_t* gather) {
  const int b = a.block_size();
  const int64_t bb = static_cast<int64_t>(b) * b;
  const int nb = a.num_block_rows();
  std::vector<int> inverse(static_cast<size_t>(nb));
  for (int k = 0; k < nb; ++k) inverse[block_of[k]] = k;
  struct Entry {
    int row;         // block row R of B
    bool transpose;  // B's block is the transpose of the stored one
    int64_t stored;  // index of S's stored block
  };
  // Block column C of B: its diagonal block, then the strictly-lower ones.
  std::vector<int> column_start(static_cast<size_t>(nb) + 1, 0);
  for (int k = 0; k < nb; ++k) {
    ++column_start[inverse[k] + 1];  // diagonal
    for (int64_t t = a.col_start()[k]; t < a.col_start()[k + 1]; ++t)
      ++column_start[std::min(inverse[a.col_rows()[t]], inverse[k]) + 1];
  }
  for (int c = 0; c < nb; ++c) column_start[c + 1] += column_start[c];
  std::vector<Entry> entries(static_cast<size_t>(column_start[nb]));
  std::vector<int> next(column_start.begin(), column_start.end() - 1);
  for (int k = 0; k < nb; ++k) {
    const int kk = inverse[k];
    entries[next[kk]++] = {kk, false, a.row_start()[k]};
    for (int64_t t = a.col_start()[k]; t < a.col_start()[k + 1]; ++t) {
      // S's upper block (i, k), i < k: B's (inverse[i], kk) or its transpose.
      const int ii = inverse[a.col_rows()[t]];
      const int64_t j = a.col_blocks()[t];
      if (ii > kk) {
        entries[next[kk]++] = {ii, false, j};
      } else {
        entries[next[ii]++] = {kk, true, j};
      }
    }
  }
  int m = 0;
  for (int c = 0; c < nb; ++c) {
    const auto first = entries.begin() + column_start[c];
    const auto last = entries.begin() + column_start[c + 1];
    std::sort(first, last, [](const Entry& x, const Entry& y) { return x.row < y.row; });
    for (int cc = 0; cc < b; ++cc) {
      bp[c * b + cc] = m;
      for (auto e = first; e != last; ++e) {
        const int64_t base = e->stored * bb;
        if (e->row == c) {  // diagonal: rows cc .. b-1, S's upper entry (cc, r)
          for (int r = cc; r < b; ++r, ++m) {
            bi[m] = c * b + r;
            gather[m] = base + static_cast<int64_t>(cc) * b + r;
          }
        } else {
          for (int r = 0; r < b; ++r, ++m) {
            bi[m] = e->row * b + r;
            gather[m] = base + (e->transpose ? static_cast<int64_t>(cc) * b + r
                                             : static_cast<int64_t>(r) * b + cc);
          }
        }
      }
    }
  }
  bp[nb * b] = m;
}

}  // namespace

struct CholmodSolver::Impl {
  Common common;
  std::shared_ptr<const CholmodOrdering> offered;  // from UseOrdering
  std::shared_ptr<const CholmodOrdering> ordering;  // of the analyzed pattern
  cholmod_sparse* permuted = nullptr;  // B = P S P^T, one triangle
  std::vector<int64_t> gather;         // B's value m is S's stored value gather[m]
  cholmod_factor* factor = nullptr;
  // Solve's dense vectors, kept across calls.
  cholmod_dense* rhs = nullptr;
  cholmod_dense* solution = nullptr;
  cholmod_dense* work_y = nullptr;
  cholmod_dense* work_e = nullptr;
  bool supernodal = false;
  bool factorized = false;
  int num_analyses = 0;
  int block_size = 0;
  int num_rows = 0;

  ~Impl() { Release(); }

  void Release() {
    cholmod_common* c = common.get();
    if (permuted != nullptr) cholmod_free_sparse(&permuted, c);
    if (factor != nullptr) cholmod_free_factor(&factor, c);
    if (rhs != nullptr) cholmod_free_dense(&rhs, c);
    if (solution != nullptr) cholmod_free_dense(&solution, c);
    if (work_y != nullptr) cholmod_free_dense(&work_y, c);
    if (work_e != nullptr) cholmod_free_dense(&work_e, c);
    ordering.reset();
    gather.clear();
  }

  Status Analyze(const BlockSparseMatrix& a);
};

// Steps 2 and 3 of the header for a's pattern.
Status CholmodSolver::Impl::Analyze(const BlockSparseMatrix& a) {
  Release();
  std::shared_ptr<const CholmodOrdering> order;
  if (offered != nullptr && offered->Orders(a)) {
    order = offered;
  } else {
    StatusOr<std::shared_ptr<const CholmodOrdering>> computed = AnalyzeCholmodOrdering(a);
    GS_RETURN_IF_ERROR(computed.status());
    order = std::move(computed).value();
  }
  const int n = a.num_rows();
  cholmod_common* c = common.get();
  supernodal = order->factor_flops >= kSupernodalSwitch * order->factor_nonzeros;

  const int b = a.block_size();
  const size_t nnz = a.col_rows().size() * static_cast<size_t>(b) * b +
                     static_cast<size_t>(a.num_block_rows()) * b * (b + 1) / 2;
  permuted = cholmod_allocate_sparse(n, n, nnz, /*sorted=*/1, /*packed=*/1,
                                     supernodal ? -1 : 1, CHOLMOD_REAL, c);
  if (permuted == nullptr) {
    return Status::Numerical(fmt::format(
        "CHOLMOD could not allocate the permuted reduced information matrix ({} rows, {} "
        "nonzeros): CHOLMOD status {}",
        n, nnz, c->status));
  }
  int* bp = static_cast<int*>(permuted->p);
  int* bi = static_cast<int*>(permuted->i);
  gather.resize(nnz);
  std::vector<int> block_of;
  if (supernodal && BlockPermutation(order->permutation, b, &block_of)) {
    BlockLowerPattern(a, block_of, bp, bi, gather.data());
  } else {
    ScalarPattern(a, order->permutation, supernodal, bp, bi, gather.data());
  }

  // B is ordered already (P includes the postorder): CHOLMOD analyses it in
  // its natural order and factorizes it without permuting or transposing.
  const int saved_nmethods = c->nmethods;
  const int saved_ordering = c->method[0].ordering;
  const int saved_postorder = c->postorder;
  c->nmethods = 1;
  c->method[0].ordering = CHOLMOD_NATURAL;
  c->postorder = 0;
  c->supernodal = supernodal ? CHOLMOD_SUPERNODAL : CHOLMOD_SIMPLICIAL;
  factor = cholmod_analyze(permuted, c);
  c->nmethods = saved_nmethods;
  c->method[0].ordering = saved_ordering;
  c->postorder = saved_postorder;
  if (factor == nullptr || c->status < CHOLMOD_OK) {
    return Status::Numerical(fmt::format(
        "CHOLMOD symbolic analysis of the reduced information matrix ({} rows, {} nonzeros "
        "in the upper triangle) failed: CHOLMOD status {}",
        n, nnz, c->status));
  }
  GS_CHECK(factor->ordering == CHOLMOD_NATURAL);
  // Keep the factor as computed (no conversion afterwards); the simplicial
  // one as LL^T, so that a non-positive pivot stops it like the supernodal.
  c->final_asis = 1;
  c->final_ll = 1;
  ordering = std::move(order);
  block_size = a.block_size();
  num_rows = n;
  ++num_analyses;
  // The factor's size and cost (what --solver auto compares; it does not
  // analyse above its unknowns budget, so -v gives them here too).
  GS_VLOG(1, "CHOLMOD analysis: %d rows, %zu nonzeros in the upper triangle, factor %.3g "
          "nonzeros (lnz), %.3g flops (fl), %s", n, nnz, ordering->factor_nonzeros,
          ordering->factor_flops, supernodal ? "supernodal" : "simplicial");
  return Status::Ok();
}

CholmodSolver::CholmodSolver() : impl_(std::make_unique<Impl>()) {}

CholmodSolver::~CholmodSolver() = default;

void CholmodSolver::UseOrdering(std::shared_ptr<const CholmodOrdering> ordering) {
  impl_->offered = std::move(ordering);
}

int CholmodSolver::num_analyses() const { return impl_->num_analyses; }
bool CholmodSolver::supernodal() const { return impl_->supernodal; }
bool CholmodSolver::factorized() const { return impl_->factorized; }
int CholmodSolver::num_rows() const { return impl_->num_rows; }

Status CholmodSolver::Factorize(const BlockSparseMatrix& a) {
  Impl& impl = *impl_;
  impl.factorized = false;
  if (a.num_rows() == 0) {  // nothing to factorize; CHOLMOD is not called
    impl.Release();
    impl.num_rows = 0;
    impl.block_size = a.block_size();
    impl.factorized = true;
    return Status::Ok();
  }
  if (impl.ordering == nullptr || !impl.ordering->Orders(a)) {
    GS_RETURN_IF_ERROR(impl.Analyze(a));
  }
  const double* values = a.StoredBlock(0);
  double* bx = static_cast<double*>(impl.permuted->x);
  const size_t nnz = impl.gather.size();
  for (size_t m = 0; m < nnz; ++m) bx[m] = values[impl.gather[m]];

  cholmod_common* c = impl.common.get();
  const SerialOpenMpRegions serial_openmp;
  cholmod_factorize(impl.permuted, impl.factor, c);
  const int status = c->status;
  const cholmod_factor* factor = impl.factor;
  if (status == CHOLMOD_NOT_POSDEF || (status >= CHOLMOD_OK && factor->minor < factor->n)) {
    // minor is the first column of B where the factorization failed; the
    // permutation maps it back to a row of S.
    long column = static_cast<long>(factor->minor);
    if (column < impl.num_rows) column = impl.ordering->permutation[column];
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
  Impl& impl = *impl_;
  GS_CHECK(impl.factorized);
  if (b.size() != impl.num_rows) {
    return Status::InvalidArgument(fmt::format(
        "CholmodSolver::Solve: right-hand side has {} rows, the factorized matrix {}", b.size(),
        impl.num_rows));
  }
  const int n = impl.num_rows;
  if (n == 0) {
    x->resize(0);
    return Status::Ok();
  }
  cholmod_common* c = impl.common.get();
  if (impl.rhs == nullptr) {
    impl.rhs = cholmod_allocate_dense(n, 1, n, CHOLMOD_REAL, c);
    if (impl.rhs == nullptr) {
      return Status::Numerical(fmt::format(
          "CHOLMOD could not allocate a right-hand side of {} rows: CHOLMOD status {}", n,
          c->status));
    }
  }
  const std::vector<int>& perm = impl.ordering->permutation;
  double* pb = static_cast<double*>(impl.rhs->x);
  for (int k = 0; k < n; ++k) pb[k] = b[perm[k]];
  const int ok = cholmod_solve2(CHOLMOD_A, impl.factor, impl.rhs, nullptr, &impl.solution,
                                nullptr, &impl.work_y, &impl.work_e, c);
  if (!ok || impl.solution == nullptr) {
    return Status::Numerical(fmt::format(
        "CHOLMOD solve with the reduced information matrix failed: CHOLMOD status {}",
        c->status));
  }
  const double* px = static_cast<const double*>(impl.solution->x);
  x->resize(n);
  for (int k = 0; k < n; ++k) (*x)[perm[k]] = px[k];
  if (!x->allFinite()) {
    return Status::Numerical("CHOLMOD solve with the reduced information matrix produced "
                             "non-finite values");
  }
  return Status::Ok();
}

}  // namespace graphslam::core
