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
// EliminateFeature emits only the feature's terms (the -Y_p Y_q^T blocks for
// every pair p <= q including the diagonal, and the +Y_p L^{-1} g_m rhs
// pieces); the caller adds A and -g_x itself. Features are independent, so
// many can be eliminated in parallel into separate ReducedContribution
// buffers and accumulated afterwards.
//
// C must be positive definite (ARCHITECTURE.md "Numerics that matter": a
// feature seen once by bearing only is not); otherwise EliminateFeature
// returns Status::Numerical and the caller keeps the feature out of the solve.
//
// THREAD SAFETY: EliminateFeature and RecoverFeature are pure functions of
// their inputs; concurrent calls must use distinct `out` buffers.
// AccumulateContribution writes S and rhs: one caller at a time per matrix.
//
// ALLOCATION: EliminateFeature works in fixed-capacity stack matrices
// (d <= kMaxFeatureDim, b <= kMaxPoseBlockSize) and only appends to `out`,
// whose vectors keep their capacity across Clear(); after warm-up it does not
// allocate. RecoverFeature returns a new d-vector. AccumulateContribution
// does not allocate.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
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

// The feature's terms of the reduced system, in triplet form.
struct ReducedContribution {
  int block_size = 0;          // b; 0 until the first EliminateFeature sets it
  std::vector<int> rows;       // block (rows[j], cols[j]) gets values[j*b*b ...]
  std::vector<int> cols;       // (AddBlock semantics: also its transpose at (cols, rows))
  std::vector<double> values;  // b*b per block, row-major
  std::vector<int> rhs_rows;   // rhs block rhs_rows[j] gets rhs_values[j*b ...]
  std::vector<double> rhs_values;  // b per row

  // Empties the lists and resets block_size, keeping the capacity.
  void Clear();
};

// Appends the feature's Schur terms to *out (see the header comment). On a
// non-positive-definite C (LLT fails, or min eigenvalue <= 1e-12 * max
// eigenvalue, or non-finite entries) returns Status::Numerical and leaves *out
// unchanged. Requires 1 <= d <= kMaxFeatureDim, every H_pm of size b x d with
// 1 <= b <= kMaxPoseBlockSize, and b == out->block_size if that is set.
[[nodiscard]] Status EliminateFeature(const FeatureBlocks& f, ReducedContribution* out);

// dm = -C^{-1} (g_m + sum_p H_pm^T dx_p), where dx_p is the segment
// [b*p, b*p + b) of `pose_delta`. C must be positive definite (a feature
// EliminateFeature accepted).
Eigen::VectorXd RecoverFeature(const FeatureBlocks& f, const Eigen::VectorXd& pose_delta);

// S += the blocks of `c` (each also transposed, as AddBlock does) and
// rhs += its rhs pieces. Every block must be in S's pattern (GS_CHECK);
// rhs has S->num_rows() entries.
void AccumulateContribution(const ReducedContribution& c, BlockSparseMatrix* s,
                            Eigen::VectorXd* rhs);

// The distinct (row, col) block positions of a ReducedContribution and, per
// entry j, which of them it is: many features of a chunk fill the same few
// pose pairs, so AccumulateContribution with groups looks each position up in
// S once instead of once per entry (the per-entry binary searches were ~12 %
// of a streaming pass, perf on store1e7). Built where the contribution is
// (in parallel), used by the serial merge.
struct ContributionGroups {
  std::vector<std::pair<int, int>> positions;  // (row, col), in order of first entry
  std::vector<int32_t> of_entry;               // per entry of c: index into positions

  // Rebuilds both lists for `c` in O(entries) (a hash table kept across calls).
  void Build(const ReducedContribution& c);

 private:
  std::vector<uint64_t> keys_;
  std::vector<int32_t> slots_;
};

// The same sums as AccumulateContribution(c, s, rhs), added in the same order
// (same bits), with one lookup in S per position of `groups` (built for c).
void AccumulateContribution(const ReducedContribution& c, const ContributionGroups& groups,
                            BlockSparseMatrix* s, Eigen::VectorXd* rhs);

}  // namespace graphslam::core
