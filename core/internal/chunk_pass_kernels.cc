#include "core/internal/chunk_pass_kernels.h"

#include <string>

#include "core/check.h"

namespace graphslam::core::internal {
namespace {

template <class Space>
bool Excluded(const BasicPassContext<Space>& context, int32_t feature) {
  return context.excluded != nullptr && (*context.excluded)[feature] != 0;
}

template <int D>
Eigen::Matrix<double, D, 1> DampingDiagonal(const Eigen::MatrixXd& information) {
  return information.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
}

}  // namespace

namespace {

// *stored (row-major P x P) += m.
template <int P>
void AddTo(const Eigen::Matrix<double, P, P>& m, double* stored) {
  for (int r = 0; r < P; ++r)
    for (int c = 0; c < P; ++c) stored[r * P + c] += m(r, c);
}

// The direct gradient and diagonal of `row`, summed in out's per-row lists
// (indexed by the row's rhs slot, which is returned).
template <class Space>
int32_t AddDirectGradient(int row, const typename ReduceOutput<Space>::Vector& gradient,
                          const typename ReduceOutput<Space>::Vector& diagonal,
                          ReduceOutput<Space>* out) {
  using Vector = typename ReduceOutput<Space>::Vector;
  const int32_t slot = out->contribution.RhsSlot(row);
  const auto index = static_cast<size_t>(slot);
  if (index == out->gradients.size()) {
    out->gradient_rows.push_back(row);
    out->gradients.push_back(gradient);
    out->diagonals.push_back(diagonal);
  } else {
    // Rows a Schur term opened first (none today) start at zero.
    while (out->gradients.size() <= index) {
      out->gradient_rows.push_back(out->contribution.rhs_row(out->gradients.size()));
      out->gradients.push_back(Vector::Zero());
      out->diagonals.push_back(Vector::Zero());
    }
    out->gradients[index] += gradient;
    out->diagonals[index] += diagonal;
  }
  double* rhs = out->contribution.RhsAt(slot);
  for (int r = 0; r < Space::kPoseDim; ++r) rhs[r] -= gradient[r];
  return slot;
}

}  // namespace

template <class Space>
Status ReduceChunk(const BasicPassContext<Space>& context,
                   const BasicObservationChunk<typename Space::Observation>& chunk,
                   const std::vector<typename Space::Pose>& poses,
                   const typename Space::PoseFrame* frames,
                   const FeatureLookup<typename Space::Point>& features, double lambda,
                   ReduceOutput<Space>* out) {
  constexpr int P = Space::kPoseDim;
  constexpr int D = Space::kFeatureDim;
  using Block = Eigen::Matrix<double, P, P>;
  using Vector = typename ReduceOutput<Space>::Vector;
  out->contribution.Clear();
  out->contribution.SetBlockSize(P);
  out->gradient_rows.clear();
  out->gradients.clear();
  out->diagonals.clear();
  out->chi2 = 0.0;
  for (int64_t k = 0; k < chunk.num_features(); ++k) {
    const int32_t g = chunk.features[k];
    if (Excluded(context, g)) continue;
    BasicLinearizedFeature<Space>& f = out->scratch;
    LinearizeFeature<Space>(chunk, k, poses, features(k, g), *context.layout, context.kernel,
                            &f, LinearizeWhat::kAll, frames);
    out->chi2 += f.chi2;
    const size_t num_poses = f.blocks.poses.size();
    out->diagonal_slots.resize(num_poses);
    out->rhs_slots.resize(num_poses);
    for (size_t slot = 0; slot < num_poses; ++slot) {
      const int u = f.blocks.poses[slot];
      out->diagonal_slots[slot] = out->contribution.BlockSlot(u, u);
      AddTo<P>(f.pose_hessian[slot], out->contribution.BlockAt(out->diagonal_slots[slot]));
      out->rhs_slots[slot] =
          AddDirectGradient<Space>(u, f.pose_gradient[slot], f.pose_hessian[slot].diagonal(), out);
    }
    if (context.layout->IsKept(g)) {
      // Padded to the pose block size: components past D decoupled.
      const int fu = context.layout->feature_unknown_index[g];
      Block c = Block::Zero();
      c.template topLeftCorner<D, D>() = f.blocks.feature_information;
      for (int i = D; i < P; ++i) c(i, i) = 1.0;
      Vector gradient = Vector::Zero();
      gradient.template head<D>() = f.blocks.feature_gradient;
      AddTo<P>(c, out->contribution.Block(fu, fu));
      AddDirectGradient<Space>(fu, gradient, c.diagonal(), out);
      for (size_t slot = 0; slot < f.blocks.poses.size(); ++slot) {
        Block coupling = Block::Zero();
        coupling.template leftCols<D>() = f.blocks.pose_feature[slot];
        // Feature unknowns follow the poses: (u, fu) is upper.
        GS_DCHECK(f.blocks.poses[slot] < fu);
        AddTo<P>(coupling, out->contribution.Block(f.blocks.poses[slot], fu));
      }
      continue;
    }
    const Eigen::Matrix<double, D, 1> damping = DampingDiagonal<D>(f.blocks.feature_information);
    f.blocks.feature_information.diagonal() += lambda * damping;
    Status status = EliminateFeature(f.blocks, &out->contribution,
                                     {out->diagonal_slots.data(), out->rhs_slots.data()});
    if (!status.ok()) {
      return status.WithContext("chunk " + std::to_string(chunk.index) + ", feature " +
                                std::to_string(g));
    }
  }
  return Status::Ok();
}

template <class Space>
void MergeReduced(const ReduceOutput<Space>& out, ReducedSystem* system) {
  constexpr int P = Space::kPoseDim;
  AccumulateContribution(out.contribution, &system->matrix, &system->rhs);
  for (size_t j = 0; j < out.gradient_rows.size(); ++j) {
    const int64_t row = out.gradient_rows[j];
    system->gradient.template segment<P>(P * row) += out.gradients[j];
    system->hessian_diagonal.template segment<P>(P * row) += out.diagonals[j];
  }
  system->chi2 += out.chi2;
}

template <class Space>
void RecoverChunk(const BasicPassContext<Space>& context,
                  const BasicObservationChunk<typename Space::Observation>& chunk,
                  const BasicRecoveryInput<Space>& input,
                  const typename Space::PoseFrame* frames, RecoverOutput<Space>* out,
                  bool with_candidate_chi2) {
  const std::vector<typename Space::Pose>& poses = input.poses;
  const std::vector<typename Space::Point>& features = input.features;
  const double lambda = input.lambda;
  const Eigen::VectorXd& step = input.step;
  const std::vector<typename Space::Pose>& candidate_poses = input.candidate_poses;
  constexpr int P = Space::kPoseDim;
  constexpr int D = Space::kFeatureDim;
  out->sums = RecoveryResult();
  out->candidates.resize(static_cast<size_t>(chunk.num_features()));
  for (int64_t k = 0; k < chunk.num_features(); ++k) {
    const int32_t g = chunk.features[k];
    typename Space::Point& candidate = out->candidates[static_cast<size_t>(k)];
    if (Excluded(context, g)) {
      candidate = features[g];
      continue;
    }
    if (context.layout->IsKept(g)) {
      // Solved in the reduced system; its model terms are in the pose part.
      const int fu = context.layout->feature_unknown_index[g];
      candidate = features[g] + step.template segment<D>(P * fu);
      if (input.step_fraction != 1.0)
        candidate = features[g] + input.step_fraction * (candidate - features[g]);
      if (with_candidate_chi2) {
        out->sums.candidate_chi2 +=
            FeatureChi2<Space>(chunk, k, candidate_poses, candidate, context.kernel);
      }
      continue;
    }
    BasicLinearizedFeature<Space>& f = out->scratch;
    LinearizeFeature<Space>(chunk, k, poses, features[g], *context.layout, context.kernel, &f,
                            LinearizeWhat::kFeatureAndCoupling, frames);
    const Eigen::Matrix<double, D, 1> damping = DampingDiagonal<D>(f.blocks.feature_information);
    f.blocks.feature_information.diagonal() += lambda * damping;
    const Eigen::Matrix<double, D, 1> feature_step = RecoverFeature(f.blocks, step);
    candidate = features[g] + feature_step;
    if (input.step_fraction != 1.0)
      candidate = features[g] + input.step_fraction * (candidate - features[g]);
    if (with_candidate_chi2) {
      out->sums.candidate_chi2 +=
          FeatureChi2<Space>(chunk, k, candidate_poses, candidate, context.kernel);
    }
    out->sums.gradient_dot_step += f.blocks.feature_gradient.dot(feature_step);
    out->sums.damped_step_norm += feature_step.dot(damping.cwiseProduct(feature_step));
    out->sums.step_squared_norm += feature_step.squaredNorm();
    out->sums.state_squared_norm += features[g].squaredNorm();
  }
}

template <class Space>
double CandidateChi2(const BasicPassContext<Space>& context,
                     const BasicObservationChunk<typename Space::Observation>& chunk,
                     const std::vector<typename Space::Pose>& candidate_poses,
                     const std::vector<typename Space::Point>& candidates) {
  double chi2 = 0.0;
  for (int64_t k = 0; k < chunk.num_features(); ++k) {
    if (Excluded(context, chunk.features[k])) continue;
    chi2 += FeatureChi2<Space>(chunk, k, candidate_poses, candidates[static_cast<size_t>(k)],
                               context.kernel);
  }
  return chi2;
}

void MergeRecovered(const RecoveryResult& sums, RecoveryResult* result) {
  result->candidate_chi2 += sums.candidate_chi2;
  result->gradient_dot_step += sums.gradient_dot_step;
  result->damped_step_norm += sums.damped_step_norm;
  result->step_squared_norm += sums.step_squared_norm;
  result->state_squared_norm += sums.state_squared_norm;
}

#define GS_INSTANTIATE_CHUNK_PASS_KERNELS(Space)                                                  \
  template Status ReduceChunk<Space>(                                                             \
      const BasicPassContext<Space>&, const BasicObservationChunk<Space::Observation>&,           \
      const std::vector<Space::Pose>&, const Space::PoseFrame*,                                   \
      const FeatureLookup<Space::Point>&, double, ReduceOutput<Space>*);                          \
  template void MergeReduced<Space>(const ReduceOutput<Space>&, ReducedSystem*);                  \
  template void RecoverChunk<Space>(                                                              \
      const BasicPassContext<Space>&, const BasicObservationChunk<Space::Observation>&,           \
      const BasicRecoveryInput<Space>&, const Space::PoseFrame*, RecoverOutput<Space>*, bool);   \
  template double CandidateChi2<Space>(                                                           \
      const BasicPassContext<Space>&, const BasicObservationChunk<Space::Observation>&,           \
      const std::vector<Space::Pose>&, const std::vector<Space::Point>&);

GS_INSTANTIATE_CHUNK_PASS_KERNELS(Space2d)
GS_INSTANTIATE_CHUNK_PASS_KERNELS(Space3d)
#undef GS_INSTANTIATE_CHUNK_PASS_KERNELS

}  // namespace graphslam::core::internal
