// The per-chunk work and the in-order merge of the reduce and recover passes
// (core/chunk_passes.h), written once so that the separate passes (ReducePass,
// RecoverPass) and the fused one (RecoverAndReducePass) run the very same
// floating-point operations in the same order: the fused pass's next reduced
// system equals a ReducePass at the candidate bit for bit.
//
//   ReduceChunk    (Table 3): per feature of the chunk, linearize at
//                  (poses, features), damp C_d = C + lambda D_m, eliminate;
//                  direct H_pp / g_p blocks and kept features' blocks go to
//                  *out as they are.
//   MergeReduced   : adds *out into the ReducedSystem (serial, chunk order).
//   RecoverChunk   (Table 4): dm = -C_d^{-1}(g_m + sum_p H_pm^T dx_p), the
//                  candidate feature, its chi2 at the candidate poses, and the
//                  model-decrease terms.
//   MergeRecovered : adds the sums (serial, chunk order).
//
// THREAD SAFETY: the *Chunk functions write only their output and, for
// RecoverChunk, the candidate slots of the chunk's own features (a feature
// lives in exactly one chunk); the Merge functions run serially.
// ALLOCATION: outputs keep their capacity across chunks.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "core/chunk_passes.h"
#include "core/feature_linearizer.h"
#include "core/schur_eliminator.h"

namespace graphslam::core::internal {

struct ReduceOutput {
  // A block added to S as it is (not through elimination): direct pose terms
  // H_pp, and every block of a kept feature.
  struct Direct {
    int row = 0;
    int col = 0;
    Eigen::Matrix3d block;
  };
  struct DirectGradient {
    int row = 0;
    Eigen::Vector3d gradient;
    Eigen::Vector3d diagonal;
  };
  LinearizedFeature scratch;
  ReducedContribution contribution;
  std::vector<Direct> blocks;
  std::vector<DirectGradient> gradients;
  double chi2 = 0.0;
};

Status ReduceChunk(const PassContext& context, const ObservationChunk& chunk,
                   const std::vector<Pose2>& poses, const std::vector<Point2>& features,
                   double lambda, ReduceOutput* out);
void MergeReduced(const ReduceOutput& out, ReducedSystem* system);

struct RecoverOutput {
  LinearizedFeature scratch;
  RecoveryResult sums;
};

// Writes (*candidate_features)[g] for the chunk's features that are not
// excluded; *candidate_features must already have one slot per feature.
void RecoverChunk(const PassContext& context, const ObservationChunk& chunk,
                  const std::vector<Pose2>& poses, const std::vector<Point2>& features,
                  double lambda, const Eigen::VectorXd& step,
                  const std::vector<Pose2>& candidate_poses,
                  std::vector<Point2>* candidate_features, RecoverOutput* out);
void MergeRecovered(const RecoverOutput& out, RecoveryResult* result);

}  // namespace graphslam::core::internal
