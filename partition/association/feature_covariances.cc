#include "partition/association/feature_covariances.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <numeric>
#include <utility>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/chunk_passes.h"
#include "core/feature_linearizer.h"
#include "core/pose_factors.h"
#include "core/unknown_layout.h"

namespace graphslam::partition {

Status LinearizeAtSolution(const core::SolverOptions& solver_options,
                           const core::ChunkSource& chunks, const core::Problem2d& problem,
                           core::PoseMarginals* marginals, std::vector<FeatureState>* states) {
  core::UnknownLayout layout = core::UnknownLayout::FromProblem(problem);
  core::PassContext context;
  context.chunks = &chunks;
  context.layout = &layout;
  context.max_in_flight = solver_options.max_chunks_in_flight;
  context.kernel = solver_options.observation_kernel;
  core::ScreeningResult screening;
  GS_RETURN_IF_ERROR(core::ScreenFeatures(context, problem.poses, problem.features,
                                          solver_options.max_eliminated_observations,
                                          &screening));
  layout.KeepFeatures(screening.kept);
  context.excluded = &screening.excluded;
  std::vector<std::pair<int, int>> pairs;
  core::AppendPoseFactorPattern(problem, layout, &pairs);
  GS_RETURN_IF_ERROR(core::CollectReducedPattern(context, &pairs));
  core::ReducedSystem system;
  system.matrix = core::BlockSparseMatrix::FromPattern(core::UnknownLayout::kPoseDimension,
                                                       layout.num_blocks(), std::move(pairs));
  const int n = system.matrix.num_rows();
  system.rhs.setZero(n);
  system.gradient.setZero(n);
  system.hessian_diagonal.setZero(n);
  core::LinearizePoseFactors(problem, problem.poses, layout, &system.matrix, &system.gradient,
                             &system.hessian_diagonal, solver_options.pose_kernels);
  GS_RETURN_IF_ERROR(core::ReducePass(context, problem.poses, problem.features, 0.0, &system));
  GS_RETURN_IF_ERROR(marginals->Factorize(system.matrix));

  states->assign(problem.num_features(), FeatureState());
  core::ObservationChunk chunk;
  core::LinearizedFeature linearized;
  for (int64_t c = 0; c < chunks.NumChunks(); ++c) {
    GS_RETURN_IF_ERROR(chunks.Load(c, &chunk));
    for (int64_t slot = 0; slot < chunk.num_features(); ++slot) {
      const int32_t f = chunk.features[slot];
      if (screening.excluded[f]) continue;
      FeatureState& state = (*states)[f];
      core::LinearizeFeature(chunk, slot, problem.poses, problem.features[f], layout,
                             context.kernel, &linearized);
      state.information = linearized.blocks.feature_information.topLeftCorner<2, 2>();
      if (layout.IsKept(f)) {
        state.gain.blocks = {layout.feature_unknown_index[f]};
        Eigen::Matrix<double, 3, 2> select = Eigen::Matrix<double, 3, 2>::Zero();
        select.topRows<2>().setIdentity();
        state.gain.gains = {select};
        state.gain.own_covariance.setZero();
        state.usable = true;
        continue;
      }
      const Eigen::LLT<Eigen::Matrix2d> llt(state.information);
      if (llt.info() != Eigen::Success) continue;
      const Eigen::Matrix2d covariance = llt.solve(Eigen::Matrix2d::Identity());
      state.gain.own_covariance = covariance;
      const size_t k = linearized.blocks.poses.size();
      std::vector<size_t> order(k);
      std::iota(order.begin(), order.end(), size_t{0});
      std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
        return linearized.blocks.poses[a] < linearized.blocks.poses[b];
      });
      for (size_t i : order) {
        state.gain.blocks.push_back(linearized.blocks.poses[i]);
        state.gain.gains.push_back(
            Eigen::Matrix<double, 3, 2>(-linearized.blocks.pose_feature[i] * covariance));
      }
      state.usable = true;
    }
  }
  return Status::Ok();
}

Status WhitenFeatures(const core::PoseMarginals& marginals, const std::vector<FeatureState>& states,
                      const std::vector<int32_t>& features, WhitenedFeatures* out) {
  out->whitened.assign(features.size(), core::PoseMarginals::WhitenedColumns());
  out->covariance.assign(features.size(), Eigen::Matrix2d::Zero());
  tbb::enumerable_thread_specific<core::PoseMarginals::WhitenWorkspace> workspaces;
  std::vector<Status> errors(features.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, features.size(), 64),
                    [&](const tbb::blocked_range<size_t>& range) {
                      core::PoseMarginals::WhitenWorkspace& workspace = workspaces.local();
                      for (size_t i = range.begin(); i != range.end(); ++i) {
                        const core::FeatureGain& gain = states[features[i]].gain;
                        errors[i] = marginals.Whiten(gain.blocks, gain.gains, &out->whitened[i],
                                                     &workspace);
                        out->covariance[i] =
                            gain.own_covariance +
                            core::PoseMarginals::Dot(out->whitened[i], out->whitened[i]);
                      }
                    });
  for (const Status& error : errors) GS_RETURN_IF_ERROR(error);
  return Status::Ok();
}

}  // namespace graphslam::partition
