// Linearization of one feature's observations (paper Table 2 l.10-21), in the
// increment form the Schur eliminator consumes; one template for both problem
// spaces (core/problem_space.h: P = Space::kPoseDim, D = Space::kFeatureDim).
//
// For each observation o of feature m from pose p (residual e_o, Jacobians
// A_o = de/dd_p (D x P, d_p the pose increment), F_o = de/dm (D x D),
// information W):
//   C    += F^T W F          g_m += F^T W e          (feature block)
//   H_pm += A^T W F                                  (pose-feature coupling)
//   H_pp += A^T W A          g_p += A^T W e          (direct pose terms)
//   chi2 += e^T W e
// With a robust kernel (core/robust_kernel.h) W is scaled by rho'(e^T W e) and
// chi2 accumulates rho(e^T W e) (iteratively reweighted least squares).
// Observations from the same pose are summed into one slot. Anchored poses
// contribute to C and g_m only. Damping for Levenberg-Marquardt is added by the
// caller (C + lambda * D_m).
//
// frames (optional): PoseFrames(poses) (core/problem_space.h), so that the
// pose Jacobians reuse each pose's rotation; the same bits as without.
// What is computed is chosen by LinearizeWhat: the recovery reads only C, g_m
// and H_pm, the screening only C (each observation's evaluation is the
// costly part of a streaming pass: skipping the pose Jacobian skips its
// rotation, skipping the residual skips the bearing's atan2). What is
// computed is the same floating-point operations in every mode.
//
// Instantiated for Space2d and Space3d in feature_linearizer.cc.
//
// THREAD SAFETY: LinearizeFeature writes only *out. ALLOCATION: reuses out's
// storage; allocates only when a feature has more poses than any before it.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "core/observation_chunk.h"
#include "core/problem_space.h"
#include "core/robust_kernel.h"
#include "core/schur_eliminator.h"
#include "core/unknown_layout.h"

namespace graphslam::core {

template <class Space>
struct BasicLinearizedFeature {
  using PoseMatrix = Eigen::Matrix<double, Space::kPoseDim, Space::kPoseDim>;
  using PoseVector = Eigen::Matrix<double, Space::kPoseDim, 1>;
  FeatureBlocks blocks;  // C (undamped), g_m, poses (unknown indices), H_pm
  std::vector<PoseMatrix> pose_hessian;  // direct H_pp per slot of blocks.poses
  std::vector<PoseVector> pose_gradient;  // direct g_p per slot
  // H_pm per slot while the observations are summed: fixed-size, so each
  // addition unrolls (the dynamic blocks.pose_feature is filled at the end).
  std::vector<Eigen::Matrix<double, Space::kPoseDim, Space::kFeatureDim>> pose_feature_sums;
  double chi2 = 0.0;
  int32_t degenerate_observations = 0;  // range-bearing with the feature on the robot
};
using LinearizedFeature = BasicLinearizedFeature<Space2d>;
using LinearizedFeature3d = BasicLinearizedFeature<Space3d>;

// Each mode computes a subset of the one before it; the rest of *out is left
// stale (not zeroed).
enum class LinearizeWhat {
  kAll,                // everything in BasicLinearizedFeature (the reduce)
  kFeatureAndCoupling, // C, g_m, poses, H_pm, degenerate_observations (the recovery)
  kInformation,        // C and degenerate_observations (the screening); the
                       // residual is evaluated only for a kernel other than kNone
};

template <class Space>
void LinearizeFeature(const BasicObservationChunk<typename Space::Observation>& chunk,
                      int64_t feature_slot, const std::vector<typename Space::Pose>& poses,
                      const typename Space::Point& feature, const UnknownLayout& layout,
                      const RobustKernel& kernel, BasicLinearizedFeature<Space>* out,
                      LinearizeWhat what = LinearizeWhat::kAll,
                      const typename Space::PoseFrame* frames = nullptr);

// chi2 of the feature's observations at (poses, feature), without Jacobians.
template <class Space>
double FeatureChi2(const BasicObservationChunk<typename Space::Observation>& chunk,
                   int64_t feature_slot, const std::vector<typename Space::Pose>& poses,
                   const typename Space::Point& feature, const RobustKernel& kernel);

extern template void LinearizeFeature<Space2d>(const ObservationChunk&, int64_t,
                                               const std::vector<Pose2>&, const Point2&,
                                               const UnknownLayout&, const RobustKernel&,
                                               LinearizedFeature*, LinearizeWhat,
                                               const Space2d::PoseFrame*);
extern template void LinearizeFeature<Space3d>(const ObservationChunk3d&, int64_t,
                                               const std::vector<Pose3>&, const Point3&,
                                               const UnknownLayout&, const RobustKernel&,
                                               LinearizedFeature3d*, LinearizeWhat,
                                               const Space3d::PoseFrame*);
extern template double FeatureChi2<Space2d>(const ObservationChunk&, int64_t,
                                            const std::vector<Pose2>&, const Point2&,
                                            const RobustKernel&);
extern template double FeatureChi2<Space3d>(const ObservationChunk3d&, int64_t,
                                            const std::vector<Pose3>&, const Point3&,
                                            const RobustKernel&);

}  // namespace graphslam::core
