// The per-chunk work and the in-order merge of the reduce and recover passes
// (core/chunk_passes.h), written once so that the separate passes (ReducePass,
// RecoverPass) and the fused one (RecoverAndReducePass) run the very same
// floating-point operations in the same order: the fused pass's next reduced
// system equals a ReducePass at the candidate bit for bit.
//
//   ReduceChunk    (Table 3): per feature of the chunk, linearize at
//                  (poses, features), damp C_d = C + lambda D_m, eliminate;
//                  all terms (Schur terms, direct H_pp / g_p, kept features'
//                  blocks) are summed per position of S / row of rhs in *out,
//                  in the chunk's feature order.
//   MergeReduced   : adds *out's sums into the ReducedSystem (serial, chunk
//                  order): one addition per position per chunk.
//   RecoverChunk   (Table 4): dm = -C_d^{-1}(g_m + sum_p H_pm^T dx_p), the
//                  candidate feature, its chi2 at the candidate poses, and the
//                  model-decrease terms. The fused pass leaves the chi2 out:
//                  its reduce at the candidate sums the very same terms
//                  (ReduceOutput::chi2, same features, same order), so it
//                  evaluates each observation at the candidate once, not
//                  twice; CandidateChi2 gives it when that reduce failed.
//   MergeRecovered : adds the sums (serial, chunk order).
//
// Templates on the problem space (core/problem_space.h), instantiated for
// Space2d and Space3d in chunk_pass_kernels.cc.
//
// THREAD SAFETY: the *Chunk functions write only their output; the Merge
// functions run serially.
// ALLOCATION: outputs keep their capacity across chunks.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/chunk_passes.h"
#include "core/feature_linearizer.h"
#include "core/internal/slot_map.h"
#include "core/schur_eliminator.h"

namespace graphslam::core::internal {

template <class Space>
struct ReduceOutput {
  using Vector = Eigen::Matrix<double, Space::kPoseDim, 1>;
  BasicLinearizedFeature<Space> scratch;
  // The chunk's terms of S and rhs summed per position: the eliminated
  // features' Schur terms, the direct pose terms H_pp and -g_p, and every
  // block of a kept feature (C, H_pm, -g_m), in feature order.
  ReducedContribution contribution;
  // The direct gradient g_p and diag(H_pp) (kept features: g_m, diag C)
  // summed per row, indexed by the row's RhsSlot in `contribution` (every
  // row gets its direct terms before any Schur term, so the slots are
  // dense): rows in order of first use.
  std::vector<int> gradient_rows;
  std::vector<Vector> gradients;
  std::vector<Vector> diagonals;
  double chi2 = 0.0;
  // Per observing pose of the current feature: its diagonal block's and
  // rhs row's slots in `contribution` (EliminateFeature's FeatureSlots).
  std::vector<int32_t> diagonal_slots;
  std::vector<int32_t> rhs_slots;
};

// The feature estimates a kernel reads: either the solve's array (indexed by
// feature) or the chunk's own slots (indexed by k, the chunk's feature slot:
// the fused pass's candidates, which exist only per chunk).
template <class Point>
struct FeatureLookup {
  const std::vector<Point>* by_feature = nullptr;
  const Point* by_slot = nullptr;
  const Point& operator()(int64_t k, int32_t g) const {
    return by_slot != nullptr ? by_slot[k] : (*by_feature)[g];
  }
};

// frames: PoseFrames(poses) (core/problem_space.h), computed once per pass.
template <class Space>
Status ReduceChunk(const BasicPassContext<Space>& context,
                   const BasicObservationChunk<typename Space::Observation>& chunk,
                   const std::vector<typename Space::Pose>& poses,
                   const typename Space::PoseFrame* frames,
                   const FeatureLookup<typename Space::Point>& features, double lambda,
                   ReduceOutput<Space>* out);
template <class Space>
void MergeReduced(const ReduceOutput<Space>& out, ReducedSystem* system);

template <class Space>
struct RecoverOutput {
  BasicLinearizedFeature<Space> scratch;
  RecoveryResult sums;
  // Per slot k of the chunk: the candidate of feature chunk.features[k]
  // (an excluded feature's slot holds its current estimate).
  std::vector<typename Space::Point> candidates;
};

// Fills out->candidates (one per chunk slot) and out->sums; with
// with_candidate_chi2 false, out->sums.candidate_chi2 stays 0.
// frames: PoseFrames(input.poses).
template <class Space>
void RecoverChunk(const BasicPassContext<Space>& context,
                  const BasicObservationChunk<typename Space::Observation>& chunk,
                  const BasicRecoveryInput<Space>& input,
                  const typename Space::PoseFrame* frames, RecoverOutput<Space>* out,
                  bool with_candidate_chi2 = true);

// The chi2 of the chunk's features that are not excluded at
// (candidate_poses, candidates[k]), summed as RecoverChunk sums it.
template <class Space>
double CandidateChi2(const BasicPassContext<Space>& context,
                     const BasicObservationChunk<typename Space::Observation>& chunk,
                     const std::vector<typename Space::Pose>& candidate_poses,
                     const std::vector<typename Space::Point>& candidates);
void MergeRecovered(const RecoveryResult& sums, RecoveryResult* result);

}  // namespace graphslam::core::internal
