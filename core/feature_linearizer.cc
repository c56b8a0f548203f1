#include "core/feature_linearizer.h"

namespace graphslam::core {

template <class Space>
void LinearizeFeature(const BasicObservationChunk<typename Space::Observation>& chunk,
                      int64_t feature_slot, const std::vector<typename Space::Pose>& poses,
                      const typename Space::Point& feature, const UnknownLayout& layout,
                      const RobustKernel& kernel, BasicLinearizedFeature<Space>* out,
                      LinearizeWhat what, const typename Space::PoseFrame* frames) {
  constexpr int P = Space::kPoseDim;
  constexpr int D = Space::kFeatureDim;
  using FeatureMatrix = Eigen::Matrix<double, D, D>;
  using FeatureVector = Eigen::Matrix<double, D, 1>;
  const bool coupling = what != LinearizeWhat::kInformation;
  const bool pose_terms = what == LinearizeWhat::kAll;
  // The screening's C needs no residual unless a kernel reweights it.
  const bool needs_residual = coupling || kernel.type != RobustKernel::Type::kNone;
  FeatureBlocks& blocks = out->blocks;
  // Summed in fixed-size matrices (unrolled), copied into the blocks at the end.
  // The products are added with noalias(): each coefficient's sum goes
  // straight into the destination, where a temporary written as scalars and
  // read back as packets stalled on store forwarding (perf: ~40 % of this
  // function's samples on three such loads); the same operations.
  FeatureMatrix information = FeatureMatrix::Zero();
  FeatureVector gradient = FeatureVector::Zero();
  blocks.poses.clear();
  size_t used = 0;  // slots in use; vectors keep their capacity across features
  out->chi2 = 0.0;
  out->degenerate_observations = 0;

  FeatureVector residual;
  Eigen::Matrix<double, D, P> jacobian_pose;
  FeatureMatrix jacobian_feature;
  const int64_t begin = chunk.feature_begin[feature_slot];
  const int64_t end = chunk.feature_begin[feature_slot + 1];
  for (int64_t o = begin; o < end; ++o) {
    const typename Space::Observation& observation = chunk.observations[o];
    const int32_t unknown = coupling ? layout.unknown_index[observation.pose] : -1;
    const typename Space::Pose& pose = poses[observation.pose];
    const bool ok =
        frames != nullptr
            ? Space::Evaluate(observation, pose, frames[observation.pose], feature,
                              needs_residual ? &residual : nullptr,
                              unknown >= 0 ? &jacobian_pose : nullptr, &jacobian_feature)
            : Space::Evaluate(observation, pose, feature, needs_residual ? &residual : nullptr,
                              unknown >= 0 ? &jacobian_pose : nullptr, &jacobian_feature);
    if (!ok) {
      ++out->degenerate_observations;
      continue;
    }
    FeatureMatrix w = observation.information;
    if (needs_residual) {
      const double squared = residual.dot(observation.information * residual);
      if (pose_terms) out->chi2 += kernel.Cost(squared);
      w = kernel.Weight(squared) * observation.information;
    }
    const FeatureMatrix fw = jacobian_feature.transpose() * w;
    information.noalias() += fw * jacobian_feature;
    if (!coupling) continue;
    gradient.noalias() += fw * residual;

    if (unknown < 0) continue;
    size_t slot = 0;
    while (slot < used && blocks.poses[slot] != unknown) ++slot;
    if (slot == used) {
      blocks.poses.push_back(unknown);
      if (out->pose_feature_sums.size() <= used) out->pose_feature_sums.emplace_back();
      out->pose_feature_sums[slot].setZero();
      if (pose_terms) {
        if (out->pose_hessian.size() <= used) {
          out->pose_hessian.emplace_back();
          out->pose_gradient.emplace_back();
        }
        out->pose_hessian[slot].setZero();
        out->pose_gradient[slot].setZero();
      }
      ++used;
    }
    const Eigen::Matrix<double, P, D> aw = jacobian_pose.transpose() * w;
    out->pose_feature_sums[slot].noalias() += aw * jacobian_feature;
    if (!pose_terms) continue;
    out->pose_hessian[slot].noalias() += aw * jacobian_pose;
    out->pose_gradient[slot].noalias() += aw * residual;
  }
  blocks.feature_information = information;
  blocks.feature_gradient = gradient;
  // Slots past `used` are stale entries of an earlier feature.
  blocks.pose_feature.resize(used);
  for (size_t slot = 0; slot < used; ++slot) blocks.pose_feature[slot] = out->pose_feature_sums[slot];
}

template <class Space>
double FeatureChi2(const BasicObservationChunk<typename Space::Observation>& chunk,
                   int64_t feature_slot, const std::vector<typename Space::Pose>& poses,
                   const typename Space::Point& feature, const RobustKernel& kernel) {
  double chi2 = 0.0;
  Eigen::Matrix<double, Space::kFeatureDim, 1> residual;
  for (int64_t o = chunk.feature_begin[feature_slot]; o < chunk.feature_begin[feature_slot + 1];
       ++o) {
    const typename Space::Observation& observation = chunk.observations[o];
    if (!Space::Evaluate(observation, poses[observation.pose], feature, &residual, nullptr,
                         nullptr))
      continue;
    chi2 += kernel.Cost(residual.dot(observation.information * residual));
  }
  return chi2;
}

template void LinearizeFeature<Space2d>(const ObservationChunk&, int64_t,
                                        const std::vector<Pose2>&, const Point2&,
                                        const UnknownLayout&, const RobustKernel&,
                                        LinearizedFeature*, LinearizeWhat,
                                        const Space2d::PoseFrame*);
template void LinearizeFeature<Space3d>(const ObservationChunk3d&, int64_t,
                                        const std::vector<Pose3>&, const Point3&,
                                        const UnknownLayout&, const RobustKernel&,
                                        LinearizedFeature3d*, LinearizeWhat,
                                        const Space3d::PoseFrame*);
template double FeatureChi2<Space2d>(const ObservationChunk&, int64_t, const std::vector<Pose2>&,
                                     const Point2&, const RobustKernel&);
template double FeatureChi2<Space3d>(const ObservationChunk3d&, int64_t,
                                     const std::vector<Pose3>&, const Point3&,
                                     const RobustKernel&);

}  // namespace graphslam::core
