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

// Relative eigenvalue floor below which C counts as singular.
constexpr double kMinRelativeEigenvalue = 1e-12;

// C = L L^T: L's lower triangle into l (row-major, stride kMaxFeatureDim);
// false when C is not positive definite. The planar case is written out
// with the very operations of Eigen's unblocked LLT (l10 = c10 / l00,
// l11 = sqrt(c11 - l10^2)), so the factor has the same bits; it skips the
// LLT object's copy and its L1 norm, which no caller reads.
bool CholeskyFactor(const FeatureMatrix& c, double* l) {
  constexpr int kStride = kMaxFeatureDim;
  if (c.rows() == 2) {
    const double c00 = c(0, 0);
    if (c00 <= 0.0) return false;  // Eigen's test: NaN goes on, as there
    const double l00 = std::sqrt(c00);
    const double l10 = c(1, 0) / l00;
    const double x = c(1, 1) - l10 * l10;
    if (x <= 0.0) return false;
    l[0] = l00;
    l[kStride] = l10;
    l[kStride + 1] = std::sqrt(x);
    return true;
  }
  const Eigen::LLT<FeatureMatrix> llt(c);
  if (llt.info() != Eigen::Success) return false;
  const FeatureMatrix& factor = llt.matrixLLT();  // L in the lower triangle
  for (int r = 0; r < c.rows(); ++r)
    for (int col = 0; col <= r; ++col) l[r * kStride + col] = factor(r, col);
  return true;
}

// The feature's terms into *out, given L (C = L L^T, lower triangle of `l`,
// row-major with stride kMaxFeatureDim). kB, kD: the block sizes when known
// at compile time (then the loops below unroll), 0 for run-time sizes.
//   w   = L^{-1} g_m                     (forward substitution)
//   Y_p = H_pm L^{-T}, row r: L y_r = h_r  (forward substitution per row)
//   rhs_p += Y_p w;  S_pq += -Y_p Y_q^T for p <= q in ascending pose order,
// so every block lands at its upper-triangle position (i <= k) as it is.
template <int kB, int kD>
void AddFeatureTerms(const FeatureBlocks& f, const double* l, int b_runtime, int d_runtime,
                     const FeatureSlots& slots, ReducedContribution* out) {
  const int b = kB > 0 ? kB : b_runtime;
  const int d = kD > 0 ? kD : d_runtime;
  constexpr int kStride = kMaxFeatureDim;
  const int num_poses = static_cast<int>(f.poses.size());
  double w[kMaxFeatureDim];
  for (int r = 0; r < d; ++r) {
    double v = f.feature_gradient[r];
    for (int m = 0; m < r; ++m) v -= l[r * kStride + m] * w[m];
    w[r] = v / l[r * kStride + r];
  }
  std::vector<double>& whitened = out->whitened();
  whitened.resize(static_cast<size_t>(num_poses) * b * d);
  for (int p = 0; p < num_poses; ++p) {
    const double* h = f.pose_feature[p].data();  // column-major b x d
    double* y = whitened.data() + static_cast<size_t>(p) * b * d;  // row-major b x d
    for (int r = 0; r < b; ++r) {
      for (int c = 0; c < d; ++c) {
        double v = h[c * b + r];
        for (int m = 0; m < c; ++m) v -= l[c * kStride + m] * y[r * d + m];
        y[r * d + c] = v / l[c * kStride + c];
      }
    }
    double* rhs = slots.rhs != nullptr ? out->RhsAt(slots.rhs[p]) : out->Rhs(f.poses[p]);
    for (int r = 0; r < b; ++r) {
      double v = 0.0;
      for (int m = 0; m < d; ++m) v += y[r * d + m] * w[m];
      rhs[r] += v;
    }
  }
  // Ascending pose order (insertion sort: a feature has few poses).
  std::vector<int>& order = out->order();
  order.resize(static_cast<size_t>(num_poses));
  for (int p = 0; p < num_poses; ++p) {
    int a = p;
    while (a > 0 && f.poses[order[a - 1]] > f.poses[p]) {
      order[a] = order[a - 1];
      --a;
    }
    order[a] = p;
  }
  for (int a = 0; a < num_poses; ++a) {
    const int p = order[a];
    const double* yp = whitened.data() + static_cast<size_t>(p) * b * d;
    for (int c = a; c < num_poses; ++c) {
      const int q = order[c];
      const double* yq = whitened.data() + static_cast<size_t>(q) * b * d;
      double* block = c == a && slots.diagonal != nullptr ? out->BlockAt(slots.diagonal[p])
                                                          : out->Block(f.poses[p], f.poses[q]);
      for (int r = 0; r < b; ++r) {
        for (int col = 0; col < b; ++col) {
          double v = 0.0;
          for (int m = 0; m < d; ++m) v += yp[r * d + m] * yq[col * d + m];
          block[r * b + col] -= v;
        }
      }
    }
  }
}

// RecoverFeature for d = 2 in scalars: v = g_m + sum_p H_pm^T dx_p (each
// entry summed over the block's rows in order), then the two triangular
// solves with CholeskyFactor's L. The generic path's small dynamic products
// and LLT were ~6 % of a streaming solve's instructions.
Eigen::VectorXd RecoverPlanarFeature(const FeatureBlocks& f, const Eigen::VectorXd& pose_delta) {
  double l[kMaxFeatureDim * kMaxFeatureDim];
  GS_CHECK(CholeskyFactor(FeatureMatrix(f.feature_information), l));
  double v0 = f.feature_gradient[0];
  double v1 = f.feature_gradient[1];
  for (size_t p = 0; p < f.poses.size(); ++p) {
    const Eigen::MatrixXd& h = f.pose_feature[p];
    const Eigen::Index b = h.rows();
    GS_CHECK((static_cast<Eigen::Index>(f.poses[p]) + 1) * b <= pose_delta.size());
    const double* x = pose_delta.data() + f.poses[p] * b;
    const double* h0 = h.data();      // column 0 (column-major b x 2)
    const double* h1 = h.data() + b;  // column 1
    double s0 = h0[0] * x[0];
    double s1 = h1[0] * x[0];
    for (Eigen::Index r = 1; r < b; ++r) {
      s0 += h0[r] * x[r];
      s1 += h1[r] * x[r];
    }
    v0 += s0;
    v1 += s1;
  }
  // L y = v, then L^T z = y; dm = -z.
  const double l00 = l[0], l10 = l[kMaxFeatureDim], l11 = l[kMaxFeatureDim + 1];
  const double y0 = v0 / l00;
  const double y1 = (v1 - l10 * y0) / l11;
  const double z1 = y1 / l11;
  const double z0 = (y0 - l10 * z1) / l00;
  return Eigen::Vector2d(-z0, -z1);
}

}  // namespace

void ReducedContribution::Clear() {
  block_size_ = 0;
  block_slots_.Clear();
  rhs_slots_.Clear();
  positions_.clear();
  values_.clear();
  rhs_rows_.clear();
  rhs_values_.clear();
}

void ReducedContribution::SetBlockSize(int b) {
  GS_CHECK(b >= 1 && b <= kMaxPoseBlockSize);
  GS_CHECK(block_size_ == 0 || block_size_ == b);
  block_size_ = b;
}

int32_t ReducedContribution::BlockSlot(int i, int k) {
  GS_DCHECK(block_size_ > 0 && 0 <= i && i <= k);
  const size_t bb = static_cast<size_t>(block_size_) * block_size_;
  bool inserted = false;
  const int32_t slot = block_slots_.Find(internal::SlotMap::PairKey(i, k), &inserted);
  if (inserted) {
    positions_.emplace_back(i, k);
    values_.resize(values_.size() + bb, 0.0);
  }
  return slot;
}

int32_t ReducedContribution::RhsSlot(int i) {
  GS_DCHECK(block_size_ > 0 && i >= 0);
  bool inserted = false;
  const int32_t slot = rhs_slots_.Find(static_cast<uint64_t>(i), &inserted);
  if (inserted) {
    rhs_rows_.push_back(i);
    rhs_values_.resize(rhs_values_.size() + block_size_, 0.0);
  }
  return slot;
}

Status EliminateFeature(const FeatureBlocks& f, ReducedContribution* out,
                        const FeatureSlots& slots) {
  const int d = static_cast<int>(f.feature_information.rows());
  GS_CHECK(d >= 1 && d <= kMaxFeatureDim);
  GS_CHECK(f.feature_information.cols() == d);
  GS_CHECK(f.feature_gradient.size() == d);
  GS_CHECK(f.poses.size() == f.pose_feature.size());
  int b = out->block_size();
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
  double l[kMaxFeatureDim * kMaxFeatureDim];
  if (!CholeskyFactor(c, l)) {
    return Status::Numerical(fmt::format(
        "feature information is not positive definite: min eigenvalue {:g} (LLT failed)",
        min_eigenvalue));
  }
  if (f.poses.empty()) return Status::Ok();
  out->SetBlockSize(b);
  if (b == 3 && d == 2) {
    AddFeatureTerms<3, 2>(f, l, b, d, slots, out);
  } else if (b == 6 && d == 3) {
    AddFeatureTerms<6, 3>(f, l, b, d, slots, out);
  } else if (b == 3 && d == 3) {
    AddFeatureTerms<3, 3>(f, l, b, d, slots, out);
  } else {
    AddFeatureTerms<0, 0>(f, l, b, d, slots, out);
  }
  return Status::Ok();
}

Eigen::VectorXd RecoverFeature(const FeatureBlocks& f, const Eigen::VectorXd& pose_delta) {
  const int d = static_cast<int>(f.feature_information.rows());
  GS_CHECK(d >= 1 && d <= kMaxFeatureDim);
  GS_CHECK(f.poses.size() == f.pose_feature.size());
  if (d == 2) return RecoverPlanarFeature(f, pose_delta);
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

void AccumulateContribution(const ReducedContribution& c, BlockSparseMatrix* s,
                            Eigen::VectorXd* rhs) {
  GS_CHECK(rhs->size() == s->num_rows());
  if (c.num_blocks() == 0 && c.num_rhs_rows() == 0) return;
  const int b = c.block_size();
  GS_CHECK(b == s->block_size());
  for (size_t j = 0; j < c.num_blocks(); ++j) {
    const auto [i, k] = c.position(j);
    double* stored = s->MutableBlock(i, k);  // i <= k: S's upper triangle
    GS_CHECK(stored != nullptr);
    const double* v = c.block_values(j);
    for (int e = 0; e < b * b; ++e) stored[e] += v[e];
  }
  for (size_t j = 0; j < c.num_rhs_rows(); ++j) {
    const int64_t row = c.rhs_row(j);
    GS_CHECK((row + 1) * b <= rhs->size());
    const double* v = c.rhs_values(j);
    for (int r = 0; r < b; ++r) (*rhs)[row * b + r] += v[r];
  }
}

}  // namespace graphslam::core
