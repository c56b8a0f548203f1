#include "core/schur_eliminator.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include "core/check.h"

namespace graphslam::core {
namespace {

// Fixed-capacity types: stack storage, no heap allocation per feature.
using FeatureMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxFeatureDim,
                  kMaxFeatureDim>;
using FeatureVector =
    Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxFeatureDim, 1>;
using PoseFeatureMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxPoseBlockSize,
                  kMaxFeatureDim>;
using PoseMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor,
                                 kMaxPoseBlockSize, kMaxPoseBlockSize>;
using PoseVector =
    Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxPoseBlockSize, 1>;

// Relative eigenvalue floor below which C counts as singular.
constexpr double kMinRelativeEigenvalue = 1e-12;

// Y = H L^{-T}, i.e. Y L^T = H: a triangular solve from the right with L^T.
PoseFeatureMatrix Whiten(const Eigen::LLT<FeatureMatrix>& llt, const Eigen::MatrixXd& h) {
  PoseFeatureMatrix y = h;
  llt.matrixU().solveInPlace<Eigen::OnTheRight>(y);
  return y;
}

}  // namespace

void ReducedContribution::Clear() {
  block_size = 0;
  rows.clear();
  cols.clear();
  values.clear();
  rhs_rows.clear();
  rhs_values.clear();
}

Status EliminateFeature(const FeatureBlocks& f, ReducedContribution* out) {
  const int d = static_cast<int>(f.feature_information.rows());
  GS_CHECK(d >= 1 && d <= kMaxFeatureDim);
  GS_CHECK(f.feature_information.cols() == d);
  GS_CHECK(f.feature_gradient.size() == d);
  GS_CHECK(f.poses.size() == f.pose_feature.size());
  int b = out->block_size;
  if (!f.pose_feature.empty()) {
    if (b == 0) b = static_cast<int>(f.pose_feature[0].rows());
    GS_CHECK(b >= 1 && b <= kMaxPoseBlockSize);
  }
  for (size_t p = 0; p < f.poses.size(); ++p) {
    GS_CHECK(f.pose_feature[p].rows() == b && f.pose_feature[p].cols() == d);
    GS_CHECK(f.poses[p] >= 0);
    for (size_t q = 0; q < p; ++q) GS_DCHECK(f.poses[q] != f.poses[p]);
  }

  const FeatureMatrix c = f.feature_information;
  if (!c.allFinite() || !f.feature_gradient.allFinite()) {
    return Status::Numerical("feature information or gradient is not finite");
  }
  double min_eigenvalue = 0.0;
  double max_eigenvalue = 0.0;
  bool eigen_ok = true;
  if (d == 2) {
    // Closed form for the planar case (the iterative solver was a visible
    // part of a streaming pass); only the positive-definiteness test below
    // reads these, never the elimination.
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen;
    eigen.computeDirect(Eigen::Matrix2d(c), Eigen::EigenvaluesOnly);
    min_eigenvalue = eigen.eigenvalues()(0);
    max_eigenvalue = eigen.eigenvalues()(1);
    eigen_ok = eigen.info() == Eigen::Success;
  } else {
    Eigen::SelfAdjointEigenSolver<FeatureMatrix> eigen(c, Eigen::EigenvaluesOnly);
    min_eigenvalue = eigen.eigenvalues()(0);
    max_eigenvalue = eigen.eigenvalues()(d - 1);
    eigen_ok = eigen.info() == Eigen::Success;
  }
  if (!eigen_ok || max_eigenvalue <= 0.0 ||
      min_eigenvalue <= kMinRelativeEigenvalue * max_eigenvalue) {
    return Status::Numerical(fmt::format(
        "feature information is not positive definite: min eigenvalue {:g}, max eigenvalue {:g}",
        min_eigenvalue, max_eigenvalue));
  }
  const Eigen::LLT<FeatureMatrix> llt(c);
  if (llt.info() != Eigen::Success) {
    return Status::Numerical(fmt::format(
        "feature information is not positive definite: min eigenvalue {:g} (LLT failed)",
        min_eigenvalue));
  }
  if (f.poses.empty()) return Status::Ok();
  out->block_size = b;

  // w = L^{-1} g_m, so that H_pm C^{-1} g_m = Y_p w.
  FeatureVector w = f.feature_gradient;
  llt.matrixL().solveInPlace(w);

  PoseMatrix block(b, b);
  PoseVector rhs(b);
  const int num_poses = static_cast<int>(f.poses.size());
  // Y_p of the first kWhitenedOnStack poses, computed once each: the small
  // runtime-sized triangular solves were ~11 % of a streaming iteration
  // (perf, store1e7) when repeated per pair. Beyond that (features with very
  // many observations) Y_q is recomputed per pair, which gives the same bits.
  constexpr int kWhitenedOnStack = 32;
  PoseFeatureMatrix whitened[kWhitenedOnStack];
  const int stored = std::min(num_poses, kWhitenedOnStack);
  for (int q = 0; q < stored; ++q) whitened[q] = Whiten(llt, f.pose_feature[q]);
  for (int p = 0; p < num_poses; ++p) {
    const PoseFeatureMatrix yp = p < stored ? whitened[p] : Whiten(llt, f.pose_feature[p]);
    rhs.noalias() = yp * w;
    out->rhs_rows.push_back(f.poses[p]);
    out->rhs_values.insert(out->rhs_values.end(), rhs.data(), rhs.data() + b);
    for (int q = p; q < num_poses; ++q) {
      if (q == p) {
        block.noalias() = -yp * yp.transpose();
      } else if (q < stored) {
        block.noalias() = -yp * whitened[q].transpose();
      } else {
        block.noalias() = -yp * Whiten(llt, f.pose_feature[q]).transpose();
      }
      out->rows.push_back(f.poses[p]);
      out->cols.push_back(f.poses[q]);
      out->values.insert(out->values.end(), block.data(), block.data() + b * b);  // row-major
    }
  }
  return Status::Ok();
}

Eigen::VectorXd RecoverFeature(const FeatureBlocks& f, const Eigen::VectorXd& pose_delta) {
  const int d = static_cast<int>(f.feature_information.rows());
  GS_CHECK(d >= 1 && d <= kMaxFeatureDim);
  GS_CHECK(f.poses.size() == f.pose_feature.size());
  const Eigen::LLT<FeatureMatrix> llt(FeatureMatrix(f.feature_information));
  GS_CHECK(llt.info() == Eigen::Success);
  FeatureVector v = f.feature_gradient;
  for (size_t p = 0; p < f.poses.size(); ++p) {
    const Eigen::MatrixXd& h = f.pose_feature[p];
    const Eigen::Index b = h.rows();
    GS_CHECK((static_cast<Eigen::Index>(f.poses[p]) + 1) * b <= pose_delta.size());
    v.noalias() += h.transpose() * pose_delta.segment(f.poses[p] * b, b);
  }
  return -llt.solve(v);
}

namespace {

// stored += v, or stored += v^T for a lower position (i > k) of S, whose
// upper-triangle block (k, i) is the one stored; b x b, row-major.
void AddToStoredBlock(const double* v, bool transposed, int b, double* stored) {
  if (!transposed) {
    for (int e = 0; e < b * b; ++e) stored[e] += v[e];
    return;
  }
  for (int r = 0; r < b; ++r) {
    for (int col = 0; col < b; ++col) stored[r * b + col] += v[col * b + r];
  }
}

// The invariants both merges rely on: c's block size is S's and its arrays
// have matching lengths.
void CheckContributionFits(const ReducedContribution& c, const BlockSparseMatrix& s) {
  const int b = c.block_size;
  GS_CHECK(b == s.block_size());
  GS_CHECK(c.rows.size() == c.cols.size());
  GS_CHECK(c.values.size() == c.rows.size() * b * b);
  GS_CHECK(c.rhs_values.size() == c.rhs_rows.size() * b);
}

// rhs += c's right-hand-side entries, in their order.
void AddRhs(const ReducedContribution& c, Eigen::VectorXd* rhs) {
  const int b = c.block_size;
  for (size_t j = 0; j < c.rhs_rows.size(); ++j) {
    const int64_t row = c.rhs_rows[j];
    GS_CHECK(row >= 0 && (row + 1) * b <= rhs->size());
    for (int r = 0; r < b; ++r) (*rhs)[row * b + r] += c.rhs_values[j * b + r];
  }
}

}  // namespace

void AccumulateContribution(const ReducedContribution& c, BlockSparseMatrix* s,
                            Eigen::VectorXd* rhs) {
  GS_CHECK(rhs->size() == s->num_rows());
  if (c.rows.empty() && c.rhs_rows.empty()) return;
  CheckContributionFits(c, *s);
  const int b = c.block_size;
  for (size_t j = 0; j < c.rows.size(); ++j) {
    const int i = c.rows[j];
    const int k = c.cols[j];
    const double* v = c.values.data() + j * b * b;
    // S stores its upper triangle: a lower block lands transposed.
    double* stored = i <= k ? s->MutableBlock(i, k) : s->MutableBlock(k, i);
    GS_CHECK(stored != nullptr);
    AddToStoredBlock(v, /*transposed=*/i > k, b, stored);
  }
  AddRhs(c, rhs);
}

void ContributionGroups::Build(const ReducedContribution& c) {
  constexpr uint64_t kEmpty = ~uint64_t{0};  // no pair of block indices >= 0 has this key
  const size_t n = c.rows.size();
  positions.clear();
  of_entry.resize(n);
  size_t capacity = 64;
  while (capacity < 2 * n) capacity *= 2;
  int shift = 64;
  for (size_t k = capacity; k > 1; k >>= 1) --shift;
  keys_.assign(capacity, kEmpty);
  slots_.resize(capacity);
  const size_t mask = capacity - 1;
  for (size_t j = 0; j < n; ++j) {
    const uint64_t key = (static_cast<uint64_t>(static_cast<uint32_t>(c.rows[j])) << 32) |
                         static_cast<uint32_t>(c.cols[j]);
    size_t slot = static_cast<size_t>((key * 0x9E3779B97F4A7C15ull) >> shift);
    while (keys_[slot] != kEmpty && keys_[slot] != key) slot = (slot + 1) & mask;
    if (keys_[slot] == kEmpty) {
      keys_[slot] = key;
      slots_[slot] = static_cast<int32_t>(positions.size());
      positions.emplace_back(c.rows[j], c.cols[j]);
    }
    of_entry[j] = slots_[slot];
  }
}

void AccumulateContribution(const ReducedContribution& c, const ContributionGroups& groups,
                            BlockSparseMatrix* s, Eigen::VectorXd* rhs) {
  GS_CHECK(rhs->size() == s->num_rows());
  if (c.rows.empty() && c.rhs_rows.empty()) return;
  CheckContributionFits(c, *s);
  const int b = c.block_size;
  GS_CHECK(groups.of_entry.size() == c.rows.size());
  // S stores its upper triangle: the block of every position, looked up once;
  // a lower position (i > k) lands transposed in (k, i).
  std::vector<double*> target(groups.positions.size());
  for (size_t g = 0; g < groups.positions.size(); ++g) {
    const auto [i, k] = groups.positions[g];
    target[g] = i <= k ? s->MutableBlock(i, k) : s->MutableBlock(k, i);
    GS_CHECK(target[g] != nullptr);
  }
  // The entries in their order, as AccumulateContribution(c, s, rhs) adds them.
  for (size_t j = 0; j < c.rows.size(); ++j) {
    const int32_t g = groups.of_entry[j];
    const double* v = c.values.data() + j * b * b;
    AddToStoredBlock(v, /*transposed=*/c.rows[j] > c.cols[j], b, target[g]);
  }
  AddRhs(c, rhs);
}

}  // namespace graphslam::core
