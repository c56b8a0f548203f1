#include "core/subgraph_preconditioner.h"

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>
#include <numeric>

#include "core/check.h"

namespace graphslam::core {
namespace {

constexpr int kMaxFixedBlockSize = 6;
using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor,
                                  kMaxFixedBlockSize, kMaxFixedBlockSize>;
using ConstBlockMap =
    Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;
using BlockMap = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>;

double FrobeniusNorm(const double* block, int b) {
  double sum = 0.0;
  for (int j = 0; j < b * b; ++j) sum += block[j] * block[j];
  return std::sqrt(sum);
}

// FrobeniusNorm of block^T, summed in the row-major order of block^T (so
// bit-identical to the norm of a stored transpose).
double TransposedFrobeniusNorm(const double* block, int b) {
  double sum = 0.0;
  for (int r = 0; r < b; ++r)
    for (int c = 0; c < b; ++c) sum += block[c * b + r] * block[c * b + r];
  return std::sqrt(sum);
}

int Find(std::vector<int>* root, int v) {
  while ((*root)[v] != v) {
    (*root)[v] = (*root)[(*root)[v]];  // path halving
    v = (*root)[v];
  }
  return v;
}

}  // namespace

SubgraphPreconditioner::SubgraphPreconditioner() = default;
SubgraphPreconditioner::~SubgraphPreconditioner() = default;

void SubgraphPreconditioner::ChooseForest(const BlockSparseMatrix& a) {
  const int n = a.num_block_rows();
  const int b = a.block_size();
  const std::vector<int64_t>& row_start = a.row_start();
  const std::vector<int>& block_cols = a.block_cols();
  std::vector<double> diagonal_norm(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) diagonal_norm[i] = FrobeniusNorm(a.Block(i, i), b);

  struct Edge {
    double weight;
    int i, k;
  };
  std::vector<Edge> edges;
  edges.reserve(static_cast<size_t>(a.num_nonzero_blocks() - n) / 2);
  for (int i = 0; i < n; ++i) {
    for (int64_t j = row_start[i]; j < row_start[i + 1]; ++j) {
      const int k = block_cols[j];
      if (k <= i) continue;
      const double scale = std::sqrt(diagonal_norm[i] * diagonal_norm[k]);
      const double norm = FrobeniusNorm(a.StoredBlock(j), b);
      // Non-finite values are caught by Factor; rank them last here.
      const double weight = scale > 0.0 && std::isfinite(norm / scale) ? norm / scale : 0.0;
      edges.push_back({weight, i, k});
    }
  }
  // Heaviest first; ties by index so the forest is deterministic.
  std::sort(edges.begin(), edges.end(), [](const Edge& l, const Edge& r) {
    if (l.weight != r.weight) return l.weight > r.weight;
    return l.i != r.i ? l.i < r.i : l.k < r.k;
  });
  std::vector<int> root(static_cast<size_t>(n));
  std::iota(root.begin(), root.end(), 0);
  std::vector<std::vector<int>> adjacent(static_cast<size_t>(n));
  num_tree_edges_ = 0;
  for (const Edge& e : edges) {
    const int ri = Find(&root, e.i), rk = Find(&root, e.k);
    if (ri == rk) continue;
    root[ri] = rk;
    adjacent[e.i].push_back(e.k);
    adjacent[e.k].push_back(e.i);
    if (++num_tree_edges_ == n - 1) break;
  }

  // Post-order of every tree, rooted at its smallest block row (iterative DFS).
  order_.clear();
  order_.reserve(static_cast<size_t>(n));
  parent_block_.assign(static_cast<size_t>(n), -2);  // -2: not visited yet
  std::vector<std::pair<int, size_t>> stack;         // (vertex, next neighbour)
  for (int r = 0; r < n; ++r) {
    if (parent_block_[r] != -2) continue;
    parent_block_[r] = -1;
    stack.emplace_back(r, 0);
    while (!stack.empty()) {
      auto& [v, next] = stack.back();
      if (next < adjacent[v].size()) {
        const int w = adjacent[v][next++];
        if (parent_block_[w] != -2) continue;
        parent_block_[w] = v;
        stack.emplace_back(w, 0);
      } else {
        order_.push_back(v);
        stack.pop_back();
      }
    }
  }
  std::vector<int> position(static_cast<size_t>(n));
  for (int t = 0; t < n; ++t) position[order_[t]] = t;
  parent_.resize(static_cast<size_t>(n));
  for (int t = 0; t < n; ++t) {
    const int p = parent_block_[order_[t]];
    parent_[t] = p < 0 ? -1 : position[p];
    GS_CHECK(parent_[t] == -1 || parent_[t] > t);
  }
  pattern_blocks_ = a.num_nonzero_blocks();
}

bool SubgraphPreconditioner::Factor(const BlockSparseMatrix& a, bool compensate,
                                    std::vector<double>* pivot_inverse,
                                    std::vector<double>* lower, int* failed_block) const {
  const int n = num_blocks_;
  const int b = block_size_;
  const int bb = b * b;
  pivot_inverse->assign(static_cast<size_t>(n) * bb, 0.0);
  lower->assign(static_cast<size_t>(n) * bb, 0.0);
  // pivot_inverse first holds the working pivots M_ii - sum (children).
  for (int t = 0; t < n; ++t) {
    const int i = order_[t];
    std::copy_n(a.Block(i, i), bb, pivot_inverse->data() + static_cast<int64_t>(t) * bb);
  }
  if (compensate) {
    const std::vector<int64_t>& row_start = a.row_start();
    const std::vector<int>& block_cols = a.block_cols();
    const std::vector<int64_t>& col_start = a.col_start();
    const std::vector<int>& col_rows = a.col_rows();
    const std::vector<int>& col_blocks = a.col_blocks();
    std::vector<int> position(static_cast<size_t>(n));
    for (int t = 0; t < n; ++t) position[order_[t]] = t;
    for (int i = 0; i < n; ++i) {
      double* work = pivot_inverse->data() + static_cast<int64_t>(position[i]) * bb;
      // Block row i in ascending column order: the lower blocks A_ik = U_ki^T
      // (the norm of U_ki^T) through the transpose index, then the upper.
      auto compensate_block = [&](int k, double norm) {
        if (k == i || parent_block_[i] == k || parent_block_[k] == i) return;
        for (int d = 0; d < b; ++d) work[d * b + d] += norm;
      };
      for (int64_t t = col_start[i]; t < col_start[i + 1]; ++t) {
        compensate_block(col_rows[t], TransposedFrobeniusNorm(a.StoredBlock(col_blocks[t]), b));
      }
      for (int64_t j = row_start[i]; j < row_start[i + 1]; ++j) {
        compensate_block(block_cols[j], FrobeniusNorm(a.StoredBlock(j), b));
      }
    }
  }
  for (int t = 0; t < n; ++t) {
    double* work = pivot_inverse->data() + static_cast<int64_t>(t) * bb;
    const SmallMatrix pivot = ConstBlockMap(work, b, b);
    const Eigen::LLT<SmallMatrix> llt(pivot);
    SmallMatrix inverse = SmallMatrix::Identity(b, b);
    if (!pivot.allFinite() || llt.info() != Eigen::Success) {
      *failed_block = order_[t];
      return false;
    }
    llt.solveInPlace(inverse);
    if (!inverse.allFinite()) {
      *failed_block = order_[t];
      return false;
    }
    BlockMap(work, b, b) = 0.5 * (inverse + inverse.transpose());
    if (parent_[t] < 0) continue;
    const int i = order_[t], p = parent_block_[i];
    // A_pi from the stored upper triangle: U_pi, or U_ip^T.
    const SmallMatrix a_pi = p < i ? SmallMatrix(ConstBlockMap(a.Block(p, i), b, b))
                                   : SmallMatrix(ConstBlockMap(a.Block(i, p), b, b).transpose());
    const SmallMatrix l = a_pi * ConstBlockMap(work, b, b);  // L_{p,i} = A_pi P_i^{-1}
    BlockMap(lower->data() + static_cast<int64_t>(t) * bb, b, b) = l;
    BlockMap parent_work(pivot_inverse->data() + static_cast<int64_t>(parent_[t]) * bb, b, b);
    parent_work.noalias() -= l * a_pi.transpose();  // A_ip = A_pi^T
  }
  return true;
}

Status SubgraphPreconditioner::Update(const BlockSparseMatrix& a) {
  const int n = a.num_block_rows();
  for (int i = 0; i < n; ++i) {
    const double* block = a.Block(i, i);
    GS_CHECK(block != nullptr);
    for (int j = 0; j < a.block_size() * a.block_size(); ++j) {
      if (!std::isfinite(block[j])) {
        return Status::Numerical(fmt::format(
            "subgraph preconditioner: diagonal block of block row {} is not finite", i));
      }
    }
  }
  if (a.block_size() > kMaxFixedBlockSize) {
    return Status::InvalidArgument(fmt::format(
        "subgraph preconditioner: block size {} exceeds {}", a.block_size(), kMaxFixedBlockSize));
  }
  // The previous state is kept until the new factor is complete.
  if (n != num_blocks_ || a.block_size() != block_size_ ||
      a.num_nonzero_blocks() != pattern_blocks_) {
    SubgraphPreconditioner fresh;
    fresh.num_blocks_ = n;
    fresh.block_size_ = a.block_size();
    fresh.ChooseForest(a);
    std::vector<double> pivot_inverse, lower;
    int failed = -1;
    bool compensated = false;
    if (!fresh.Factor(a, false, &pivot_inverse, &lower, &failed)) {
      compensated = true;
      if (!fresh.Factor(a, true, &pivot_inverse, &lower, &failed)) {
        return Status::Numerical(fmt::format(
            "subgraph preconditioner: the spanning-tree pivot of block row {} is not positive "
            "definite even with diagonal compensation; A is not positive definite",
            failed));
      }
    }
    std::lock_guard<std::mutex> lock(mutex_);
    num_blocks_ = n;
    block_size_ = a.block_size();
    num_tree_edges_ = fresh.num_tree_edges_;
    pattern_blocks_ = fresh.pattern_blocks_;
    order_ = std::move(fresh.order_);
    parent_ = std::move(fresh.parent_);
    parent_block_ = std::move(fresh.parent_block_);
    pivot_inverse_ = std::move(pivot_inverse);
    lower_ = std::move(lower);
    compensated_ = compensated;
    scratch_.assign(static_cast<size_t>(n) * block_size_, 0.0);
    return Status::Ok();
  }
  std::vector<double> pivot_inverse, lower;
  int failed = -1;
  bool compensated = false;
  if (!Factor(a, false, &pivot_inverse, &lower, &failed)) {
    compensated = true;
    if (!Factor(a, true, &pivot_inverse, &lower, &failed)) {
      return Status::Numerical(fmt::format(
          "subgraph preconditioner: the spanning-tree pivot of block row {} is not positive "
          "definite even with diagonal compensation; A is not positive definite",
          failed));
    }
  }
  pivot_inverse_.swap(pivot_inverse);
  lower_.swap(lower);
  compensated_ = compensated;
  return Status::Ok();
}

Status SubgraphPreconditioner::SetForest(const BlockSparseMatrix& pattern,
                                         const std::vector<int>& order,
                                         const std::vector<int>& parent_block) {
  const int n = pattern.num_block_rows();
  if (static_cast<int>(order.size()) != n || static_cast<int>(parent_block.size()) != n) {
    return Status::InvalidArgument(fmt::format(
        "subgraph forest: {} order and {} parent entries for {} block rows", order.size(),
        parent_block.size(), n));
  }
  if (pattern.block_size() > kMaxFixedBlockSize) {
    return Status::InvalidArgument(fmt::format(
        "subgraph preconditioner: block size {} exceeds {}", pattern.block_size(),
        kMaxFixedBlockSize));
  }
  std::vector<int> position(static_cast<size_t>(n), -1);
  for (int t = 0; t < n; ++t) {
    const int i = order[t];
    if (i < 0 || i >= n || position[i] >= 0) {
      return Status::InvalidArgument(fmt::format(
          "subgraph forest: order entry {} is {}, not a permutation of 0..{}", t, i, n - 1));
    }
    position[i] = t;
  }
  std::vector<int> parent(static_cast<size_t>(n));
  int tree_edges = 0;
  for (int t = 0; t < n; ++t) {
    const int i = order[t], p = parent_block[i];
    if (p == -1) {
      parent[t] = -1;
      continue;
    }
    if (p < 0 || p >= n || position[p] <= t || !pattern.HasBlock(i, p)) {
      return Status::InvalidArgument(fmt::format(
          "subgraph forest: block row {} has parent {}, which is not a later-eliminated "
          "neighbour in the matrix",
          i, p));
    }
    parent[t] = position[p];
    ++tree_edges;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  num_blocks_ = n;
  block_size_ = pattern.block_size();
  num_tree_edges_ = tree_edges;
  pattern_blocks_ = pattern.num_nonzero_blocks();
  order_ = order;
  parent_ = std::move(parent);
  parent_block_ = parent_block;
  pivot_inverse_.clear();  // factored by the next Update
  lower_.clear();
  compensated_ = false;
  scratch_.assign(static_cast<size_t>(n) * block_size_, 0.0);
  return Status::Ok();
}

void SubgraphPreconditioner::RightMultiplyAndAccumulate(const double* x, double* y) const {
  const int n = num_blocks_;
  const int b = block_size_;
  const int bb = b * b;
  if (n == 0) return;
  GS_CHECK(static_cast<int>(order_.size()) == n);
  std::lock_guard<std::mutex> lock(mutex_);
  double* z = scratch_.data();
  for (int t = 0; t < n; ++t) std::copy_n(x + static_cast<int64_t>(order_[t]) * b, b, z + static_cast<int64_t>(t) * b);
  // Forward: z_p -= L_{p,i} z_i, children before parents.
  for (int t = 0; t < n; ++t) {
    const int p = parent_[t];
    if (p < 0) continue;
    const double* l = lower_.data() + static_cast<int64_t>(t) * bb;
    const double* zt = z + static_cast<int64_t>(t) * b;
    double* zp = z + static_cast<int64_t>(p) * b;
    for (int r = 0; r < b; ++r) {
      double sum = 0.0;
      for (int c = 0; c < b; ++c) sum += l[r * b + c] * zt[c];
      zp[r] -= sum;
    }
  }
  // Backward: y_i = P_i^{-1} z_i - L_{p,i}^T y_p, parents before children,
  // in place (z_p already holds y_p).
  double w[kMaxFixedBlockSize];
  GS_CHECK(b <= kMaxFixedBlockSize);
  for (int t = n - 1; t >= 0; --t) {
    const double* pinv = pivot_inverse_.data() + static_cast<int64_t>(t) * bb;
    double* zt = z + static_cast<int64_t>(t) * b;
    for (int r = 0; r < b; ++r) {
      double sum = 0.0;
      for (int c = 0; c < b; ++c) sum += pinv[r * b + c] * zt[c];
      w[r] = sum;
    }
    const int p = parent_[t];
    if (p >= 0) {
      const double* l = lower_.data() + static_cast<int64_t>(t) * bb;
      const double* yp = z + static_cast<int64_t>(p) * b;
      for (int c = 0; c < b; ++c) {
        double sum = 0.0;
        for (int r = 0; r < b; ++r) sum += l[r * b + c] * yp[r];
        w[c] -= sum;
      }
    }
    std::copy_n(w, b, zt);
  }
  for (int t = 0; t < n; ++t) {
    double* yi = y + static_cast<int64_t>(order_[t]) * b;
    const double* zt = z + static_cast<int64_t>(t) * b;
    for (int r = 0; r < b; ++r) yi[r] += zt[r];
  }
}

}  // namespace graphslam::core
