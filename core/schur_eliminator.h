// Per-feature Schur complement: eliminating one map feature from the
// linearized GraphSLAM system (Thrun & Montemerlo 2006, Table 3 "reduce",
// written for increments as in Ceres' SchurEliminator).
//
// For one feature m of dimension d (2 or 3) observed by the free poses p, the
// normal equations of the increments (A = pose-pose, B = pose-feature blocks
// H_pm, C = H_mm) read
//
//   [ A    B ] [ dx ]     [ g_x ]
//   [ B^T  C ] [ dm ] = - [ g_m ]
//
// Eliminating dm with C = L L^T (Cholesky) gives the reduced system S dx = rhs:
//
//   S   = A - B C^{-1} B^T        blocks (p,q): -H_pm C^{-1} H_qm^T = -Y_p Y_q^T,
//                                               Y_p = H_pm L^{-T}
//   rhs = -g_x + B C^{-1} g_m     per pose p:   +H_pm C^{-1} g_m = Y_p L^{-1} g_m
//
// and, once dx is known, the feature is recovered (back-substitution):
//
//   dm = -C^{-1} (g_m + sum_p H_pm^T dx_p).
//
// EliminateFeature adds only the feature's terms (the -Y_p Y_q^T blocks for
// every pair p <= q including the diagonal, and the +Y_p L^{-1} g_m rhs
// pieces); the caller adds A and -g_x itself. Features are independent, so
// many can be eliminated in parallel into separate ReducedContribution
// buffers and accumulated afterwards. A ReducedContribution sums the terms
// of all its features per block position (S's upper-triangle block (i, k),
// i <= k, and rhs block row i) as they come: a chunk's features share few
// pose pairs, so the serial merge into S adds each position once (the former
// list of one b x b entry per feature and pair cost ~13 % of a reduce pass
// in memmove and ~19 % in the serial merge, perf on store1e7;
// docs/benchmarks.md).
//
// C must be positive definite (a
// feature seen once by bearing only is not); otherwise EliminateFeature
// returns Status::Numerical and the caller keeps the feature out of the solve.
//
// THREAD SAFETY: EliminateFeature and RecoverFeature are pure functions of
// their inputs; concurrent calls must use distinct `out` buffers.
// AccumulateContribution writes S and rhs: one caller at a time per matrix.
//
// ORDER: with block sizes b, d of 3/2, 6/3 and 3/3 the arithmetic is
// written out for the fixed sizes (others take the same code with run-time
// sizes); each sum depends only on the features added to `out` and their
// order, never on threads.
//
// ALLOCATION: EliminateFeature works in fixed-capacity stack matrices
// (d <= kMaxFeatureDim, b <= kMaxPoseBlockSize) and `out`, whose sums, hash
// tables and scratch keep their capacity across Clear(); after warm-up it
// does not allocate. Its memory is O(distinct positions + poses) of what was
// added since the last Clear (a chunk's, not a whole pass's). RecoverFeature
// returns a new d-vector. AccumulateContribution does not allocate.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/internal/slot_map.h"
#include "core/status.h"

namespace graphslam::core {

inline constexpr int kMaxFeatureDim = 3;
inline constexpr int kMaxPoseBlockSize = 6;

// The blocks of the linearized system that touch one feature.
struct FeatureBlocks {
  Eigen::MatrixXd feature_information;        // C = H_mm (d x d), already damped by the caller
  Eigen::VectorXd feature_gradient;           // g_m (d)
  std::vector<int> poses;                     // block indices of the observing free poses, unique
  std::vector<Eigen::MatrixXd> pose_feature;  // H_pm for each entry of `poses` (b x d)
};

// The terms of many features, summed per position in the order they were
// added (first the sum starts at zero, then each term is added to it).
class ReducedContribution {
 public:
  // Empties the sums and resets block_size, keeping the capacity.
  void Clear();

  int block_size() const { return block_size_; }  // b; 0 until the first term
  // Fixes b (1 <= b <= kMaxPoseBlockSize); later calls must pass the same b.
  void SetBlockSize(int b);

  // The running sum of S's stored block (i, k), 0 <= i <= k: b x b, row-major,
  // zero when new. Valid until the next call of Block.
  double* Block(int i, int k) { return BlockAt(BlockSlot(i, k)); }
  // The running sum of rhs block row i (b entries), zero when new. Valid
  // until the next call of Rhs.
  double* Rhs(int i) { return RhsAt(RhsSlot(i)); }
  // The same by slot: BlockSlot / RhsSlot number the positions / rows in
  // order of first use and stay valid until Clear, so that a caller adding
  // to one position twice (the direct and the Schur term of a pose) looks
  // it up once. BlockAt / RhsAt are valid until the next new position / row.
  int32_t BlockSlot(int i, int k);
  int32_t RhsSlot(int i);
  double* BlockAt(int32_t slot) {
    return values_.data() + static_cast<size_t>(slot) * block_size_ * block_size_;
  }
  double* RhsAt(int32_t slot) { return rhs_values_.data() + static_cast<size_t>(slot) * block_size_; }

  // The positions, in order of first use, and their sums.
  size_t num_blocks() const { return positions_.size(); }
  std::pair<int, int> position(size_t j) const { return positions_[j]; }
  const double* block_values(size_t j) const {
    return values_.data() + j * block_size_ * block_size_;
  }
  size_t num_rhs_rows() const { return rhs_rows_.size(); }
  int rhs_row(size_t j) const { return rhs_rows_[j]; }
  const double* rhs_values(size_t j) const { return rhs_values_.data() + j * block_size_; }

  // EliminateFeature's per-feature scratch (the whitened Y_p and the poses'
  // ascending order); kept here so that it keeps its capacity too.
  std::vector<double>& whitened() { return whitened_; }
  std::vector<int>& order() { return order_; }

 private:
  int block_size_ = 0;
  internal::SlotMap block_slots_;  // key (i, k) -> index into positions_
  internal::SlotMap rhs_slots_;    // key i -> index into rhs_rows_
  std::vector<std::pair<int, int>> positions_;
  std::vector<double> values_;      // b*b per position
  std::vector<int> rhs_rows_;
  std::vector<double> rhs_values_;  // b per rhs row
  std::vector<double> whitened_;
  std::vector<int> order_;
};

// Adds the feature's Schur terms to *out (see the header comment). On a
// non-positive-definite C (LLT fails, or min eigenvalue <= 1e-12 * max
// eigenvalue, or non-finite entries) returns Status::Numerical and leaves *out
// unchanged. Requires 1 <= d <= kMaxFeatureDim, every H_pm of size b x d with
// 1 <= b <= kMaxPoseBlockSize, and b == out->block_size if that is set.
//
// slots (optional): per entry p of f.poses, the BlockSlot of (poses[p],
// poses[p]) and the RhsSlot of poses[p] in *out, when the caller has them
// already; the very same sums, with fewer lookups.
struct FeatureSlots {
  const int32_t* diagonal = nullptr;
  const int32_t* rhs = nullptr;
};
[[nodiscard]] Status EliminateFeature(const FeatureBlocks& f, ReducedContribution* out,
                                      const FeatureSlots& slots = {});

// dm = -C^{-1} (g_m + sum_p H_pm^T dx_p), where dx_p is the segment
// [b*p, b*p + b) of `pose_delta`. C must be positive definite (a feature
// EliminateFeature accepted).
Eigen::VectorXd RecoverFeature(const FeatureBlocks& f, const Eigen::VectorXd& pose_delta);

// S += every block sum of `c` (at its upper-triangle position) and rhs +=
// its rhs sums, one lookup in S per position. Every position must be in S's
// pattern (GS_CHECK); rhs has S->num_rows() entries.
void AccumulateContribution(const ReducedContribution& c, BlockSparseMatrix* s,
                            Eigen::VectorXd* rhs);

}  // namespace graphslam::core
