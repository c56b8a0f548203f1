#include "core/internal/chunk_pass_kernels.h"

#include <string>

namespace graphslam::core::internal {
namespace {

constexpr int kDim = UnknownLayout::kPoseDimension;

bool Excluded(const PassContext& context, int32_t feature) {
  return context.excluded != nullptr && (*context.excluded)[feature] != 0;
}

Eigen::Vector2d DampingDiagonal(const Eigen::MatrixXd& information) {
  return information.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
}

}  // namespace

Status ReduceChunk(const PassContext& context, const ObservationChunk& chunk,
                   const std::vector<Pose2>& poses, const std::vector<Point2>& features,
                   double lambda, ReduceOutput* out) {
  out->contribution.Clear();
  out->blocks.clear();
  out->gradients.clear();
  out->chi2 = 0.0;
  for (int64_t k = 0; k < chunk.num_features(); ++k) {
    const int32_t g = chunk.features[k];
    if (Excluded(context, g)) continue;
    LinearizedFeature& f = out->scratch;
    LinearizeFeature(chunk, k, poses, features[g], *context.layout, context.kernel, &f);
    out->chi2 += f.chi2;
    for (size_t slot = 0; slot < f.blocks.poses.size(); ++slot) {
      const int u = f.blocks.poses[slot];
      out->blocks.push_back({u, u, f.pose_hessian[slot]});
      out->gradients.push_back({u, f.pose_gradient[slot], f.pose_hessian[slot].diagonal()});
    }
    if (context.layout->IsKept(g)) {
      // Padded to the pose block size: third component decoupled.
      const int fu = context.layout->feature_unknown_index[g];
      Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
      c.topLeftCorner<2, 2>() = f.blocks.feature_information;
      c(2, 2) = 1.0;
      Eigen::Vector3d gradient = Eigen::Vector3d::Zero();
      gradient.head<2>() = f.blocks.feature_gradient;
      out->blocks.push_back({fu, fu, c});
      out->gradients.push_back({fu, gradient, c.diagonal()});
      for (size_t slot = 0; slot < f.blocks.poses.size(); ++slot) {
        Eigen::Matrix3d coupling = Eigen::Matrix3d::Zero();
        coupling.leftCols<2>() = f.blocks.pose_feature[slot];
        out->blocks.push_back({f.blocks.poses[slot], fu, coupling});
      }
      continue;
    }
    const Eigen::Vector2d damping = DampingDiagonal(f.blocks.feature_information);
    f.blocks.feature_information.diagonal() += lambda * damping;
    Status status = EliminateFeature(f.blocks, &out->contribution);
    if (!status.ok()) {
      return status.WithContext("chunk " + std::to_string(chunk.index) + ", feature " +
                                std::to_string(g));
    }
  }
  return Status::Ok();
}

void MergeReduced(const ReduceOutput& out, ReducedSystem* system) {
  AccumulateContribution(out.contribution, &system->matrix, &system->rhs);
  for (const ReduceOutput::Direct& d : out.blocks)
    GS_CHECK(system->matrix.AddBlock(d.row, d.col, d.block));
  for (const ReduceOutput::DirectGradient& d : out.gradients) {
    system->gradient.segment<kDim>(kDim * d.row) += d.gradient;
    system->rhs.segment<kDim>(kDim * d.row) -= d.gradient;
    system->hessian_diagonal.segment<kDim>(kDim * d.row) += d.diagonal;
  }
  system->chi2 += out.chi2;
}

void RecoverChunk(const PassContext& context, const ObservationChunk& chunk,
                  const std::vector<Pose2>& poses, const std::vector<Point2>& features,
                  double lambda, const Eigen::VectorXd& step,
                  const std::vector<Pose2>& candidate_poses,
                  std::vector<Point2>* candidate_features, RecoverOutput* out) {
  out->sums = RecoveryResult();
  for (int64_t k = 0; k < chunk.num_features(); ++k) {
    const int32_t g = chunk.features[k];
    if (Excluded(context, g)) continue;
    if (context.layout->IsKept(g)) {
      // Solved in the reduced system; its model terms are in the pose part.
      const int fu = context.layout->feature_unknown_index[g];
      (*candidate_features)[g] = features[g] + step.segment<2>(kDim * fu);
      out->sums.candidate_chi2 +=
          FeatureChi2(chunk, k, candidate_poses, (*candidate_features)[g], context.kernel);
      continue;
    }
    LinearizedFeature& f = out->scratch;
    LinearizeFeature(chunk, k, poses, features[g], *context.layout, context.kernel, &f);
    const Eigen::Vector2d damping = DampingDiagonal(f.blocks.feature_information);
    f.blocks.feature_information.diagonal() += lambda * damping;
    const Eigen::Vector2d feature_step = RecoverFeature(f.blocks, step);
    // Each feature lives in exactly one chunk: no two tasks write one slot.
    (*candidate_features)[g] = features[g] + feature_step;
    out->sums.candidate_chi2 +=
        FeatureChi2(chunk, k, candidate_poses, (*candidate_features)[g], context.kernel);
    out->sums.gradient_dot_step += f.blocks.feature_gradient.dot(feature_step);
    out->sums.damped_step_norm += feature_step.dot(damping.cwiseProduct(feature_step));
    out->sums.step_squared_norm += feature_step.squaredNorm();
    out->sums.state_squared_norm += features[g].squaredNorm();
  }
}

void MergeRecovered(const RecoverOutput& out, RecoveryResult* result) {
  result->candidate_chi2 += out.sums.candidate_chi2;
  result->gradient_dot_step += out.sums.gradient_dot_step;
  result->damped_step_norm += out.sums.damped_step_norm;
  result->step_squared_norm += out.sums.step_squared_norm;
  result->state_squared_norm += out.sums.state_squared_norm;
}

}  // namespace graphslam::core::internal
