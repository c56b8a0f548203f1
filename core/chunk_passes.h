// The streaming passes over observation chunks that one GraphSLAM iteration
// makes (paper Tables 2-4, in increment form with Levenberg-Marquardt damping).
//
//   ScreenFeatures: which features can be eliminated at all. A feature whose
//     information C = sum F^T W F is not positive definite (e.g. seen once by a
//     bearing-only sensor, or unobserved) is kept out of the solve and reported.
//     A feature with more than max_eliminated_observations observations is
//     "kept": an unknown of the reduced system instead of eliminated
//     (UnknownLayout), so its k observing poses add k blocks, not k^2.
//   CollectReducedPattern: the pose pairs the reduced matrix couples: all pairs
//     of free poses observing a common feature. ScreenFeatures collects the
//     same pairs in its own pass when given a ScreenedPattern (one read of the
//     chunks for the setup instead of two); KeptFeaturePattern then adds the
//     kept features' pairs, once UnknownLayout::KeepFeatures has numbered them.
//   ReducePass (Table 3): for each feature, C_d = C + lambda D_m and
//       S   += H_pp - H_pm C_d^{-1} H_qm^T       (all p, q observing it)
//       rhs += -g_p + H_pm C_d^{-1} g_m
//   Kept features add their blocks to S directly (C, H_pm, g_m), padded to the
//     pose block size (UnknownLayout).
//   RecoverPass (Table 4): dm = -C_d^{-1}(g_m + sum_p H_pm^T dx_p), the
//     candidate feature m + dm, and its chi2 at the candidate poses; plus the
//     terms g_m^T dm and dm^T D_m dm of the Levenberg-Marquardt model decrease.
//   RecoverAndReducePass: RecoverPass and, in the same visit of each chunk, a
//     ReducePass at the candidate (poses x + dx, features m + dm) with the
//     damping lambda' the next iteration will use if the step is accepted: one
//     read of the chunks per Gauss-Newton iteration instead of two. Both halves
//     run the code of the separate passes (core/internal/chunk_pass_kernels.h),
//     so the speculative system equals ReducePass at the candidate bit for bit.
// D_m is diag(C) clamped to [kMinDiagonal, kMaxDiagonal] (as Ceres does).
//
// One implementation for both problem spaces (core/problem_space.h): every
// pass is a template on the Space (planar: 3 x 3 pose blocks, 2-D features;
// 3-D: 6 x 6 pose blocks, 3-D points), whose block sizes are compile-time
// constants in the linearization and elimination loops. The templates are
// defined and explicitly instantiated for Space2d and Space3d in
// chunk_passes.cc; PassContext / PassContext3d select the space.
//
// THREAD SAFETY: each pass runs chunks in parallel (TBB) and merges their
// results in chunk order, so results do not depend on the thread count.
// ALLOCATION: bounded by max_in_flight chunks plus the caller's outputs.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <utility>
#include <vector>

#include "core/block_sparse_matrix.h"
#include "core/chunk_source.h"
#include "core/problem.h"
#include "core/problem_space.h"
#include "core/progress.h"
#include "core/robust_kernel.h"
#include "core/status.h"
#include "core/unknown_layout.h"

namespace graphslam::core {

inline constexpr double kMinDiagonal = 1e-6;
inline constexpr double kMaxDiagonal = 1e32;

template <class Space>
struct BasicPassContext {
  using Source = BasicChunkSource<typename Space::Observation>;
  const Source* chunks = nullptr;                  // must outlive the pass
  const UnknownLayout* layout = nullptr;       // must outlive the pass
  const std::vector<uint8_t>* excluded = nullptr;  // per feature; 1 = out of the solve
  RobustKernel kernel;                             // applied to every observation
  int max_in_flight = 4;
  ProgressCallback progress;  // optional
};
using PassContext = BasicPassContext<Space2d>;
using PassContext3d = BasicPassContext<Space3d>;

struct ScreeningResult {
  std::vector<uint8_t> excluded;    // per feature
  std::vector<uint8_t> kept;        // per feature: unknown of the reduced system
  int64_t kept_count = 0;
  int64_t excluded_not_positive_definite = 0;
  int64_t unobserved = 0;
  int64_t observations = 0;         // observations of eliminable features
};

// The pattern ScreenFeatures collects along: what CollectReducedPattern
// would give with the screening's partition (context.excluded = result's
// excluded, layout.KeepFeatures(result's kept)).
struct ScreenedPattern {
  // Pairs of free poses observing a common eliminated feature; each pair once
  // per chunk (duplicates across chunks remain: FromPattern removes them).
  std::vector<std::pair<int, int>> pose_pairs;
  // (feature, free pose) for every kept feature and each pose observing it.
  std::vector<std::pair<int32_t, int>> kept_observers;
};

// pattern (optional): also collect the reduced matrix's pattern in this pass.
template <class Space>
Status ScreenFeatures(const BasicPassContext<Space>& context,
                      const std::vector<typename Space::Pose>& poses,
                      const std::vector<typename Space::Point>& features,
                      int64_t max_eliminated_observations, ScreeningResult* result,
                      ScreenedPattern* pattern = nullptr);

// Appends pattern.pose_pairs and the kept features' pairs (fu, fu), (u, fu)
// with layout's numbering (after layout.KeepFeatures) to *pairs; consumes
// *pattern.
void AppendScreenedPattern(const UnknownLayout& layout, ScreenedPattern* pattern,
                           std::vector<std::pair<int, int>>* pairs);

template <class Space>
Status CollectReducedPattern(const BasicPassContext<Space>& context,
                             std::vector<std::pair<int, int>>* pairs);

struct ReducedSystem {
  BlockSparseMatrix matrix;         // S, pattern fixed; filled by ReducePass
  Eigen::VectorXd rhs;              // S dx = rhs
  Eigen::VectorXd gradient;         // full (unreduced) pose gradient g_x
  Eigen::VectorXd hessian_diagonal; // diag of the full (unreduced) H_xx, for damping
  double chi2 = 0.0;                // chi2 of the observations at the linearization point
};

// Adds the observation terms into `system` (which the caller has zeroed and
// into which it may already have added pose-only factors).
template <class Space>
Status ReducePass(const BasicPassContext<Space>& context,
                  const std::vector<typename Space::Pose>& poses,
                  const std::vector<typename Space::Point>& features, double lambda,
                  ReducedSystem* system);

// `step` is the solution of the reduced system: poses, then kept features.
struct RecoveryResult {
  double candidate_chi2 = 0.0;     // observations at (candidate poses, candidate features)
  double gradient_dot_step = 0.0;  // sum g_m^T dm over eliminated features
  double damped_step_norm = 0.0;   // sum dm^T D_m dm
  double step_squared_norm = 0.0;  // sum |dm|^2
  double state_squared_norm = 0.0; // sum |m|^2
};

// Receives the candidates of each chunk, serially and in chunk order: slot k
// is the candidate of chunk.features[k] (an excluded feature's slot holds its
// current estimate). The streaming solve writes them to disk
// (core/candidate_store.h) instead of holding one per feature in memory. A
// non-OK Status is returned by the pass (later chunks are not given to it).
template <class Space>
using CandidateSink =
    std::function<Status(const BasicObservationChunk<typename Space::Observation>& chunk,
                         const std::vector<typename Space::Point>& candidates)>;

// What a recovery starts from: the linearization point (poses, features),
// the damping `lambda` of the solved system, its solution `step` and the
// candidate poses x + dx. The references must outlive the pass.
// step_fraction t != 1 (a line search along a rejected step, whose
// candidates were not kept): each candidate m + dm becomes m + t ((m + dm) - m)
// before its chi2 is summed and it is handed to the sink, the very
// arithmetic of the in-memory line search; candidate_poses are then the
// poses at x (+) t dx, and the model sums stay those of the whole step.
template <class Space>
struct BasicRecoveryInput {
  const std::vector<typename Space::Pose>& poses;
  const std::vector<typename Space::Point>& features;
  double lambda;
  const Eigen::VectorXd& step;
  const std::vector<typename Space::Pose>& candidate_poses;
  double step_fraction = 1.0;
};

template <class Space>
Status RecoverPass(const BasicPassContext<Space>& context, const BasicRecoveryInput<Space>& input,
                   const CandidateSink<Space>& sink, RecoveryResult* result);

// RecoverPass into one slot per feature: (*candidate_features)[g] for every
// feature of a chunk that is not excluded (others keep their value).
template <class Space>
Status RecoverPass(const BasicPassContext<Space>& context, const BasicRecoveryInput<Space>& input,
                   std::vector<typename Space::Point>* candidate_features,
                   RecoveryResult* result);

// The second half of the fused pass: the next system, reduced at the
// candidates with damping `lambda`, into *system; *status receives a failed
// elimination there.
struct NextReduction {
  double lambda = 0.0;
  ReducedSystem* system = nullptr;
  Status* status = nullptr;
};

// RecoverPass plus ReducePass(candidate_poses, candidates, next.lambda) into
// *next.system, which the caller has zeroed and into which it may already
// have added the pose-only factors at the candidate poses. A failed
// elimination at the candidate is not an error of the pass (the step may be
// rejected anyway): it is returned in *next.status and *next.system is then
// partial. The returned Status is the recovery's (chunk loading, the sink).
template <class Space>
Status RecoverAndReducePass(const BasicPassContext<Space>& context,
                            const BasicRecoveryInput<Space>& input,
                            const CandidateSink<Space>& sink, RecoveryResult* result,
                            const NextReduction& next);

// The same with one candidate slot per feature (as RecoverPass above).
template <class Space>
Status RecoverAndReducePass(const BasicPassContext<Space>& context,
                            const BasicRecoveryInput<Space>& input,
                            std::vector<typename Space::Point>* candidate_features,
                            RecoveryResult* result, const NextReduction& next);

// chi2 of all observations of eliminable features at (poses, features).
template <class Space>
Status ObservationsChi2(const BasicPassContext<Space>& context,
                        const std::vector<typename Space::Pose>& poses,
                        const std::vector<typename Space::Point>& features, double* chi2);

}  // namespace graphslam::core
