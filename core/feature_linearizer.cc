#include "core/feature_linearizer.h"

namespace graphslam::core {

template <class Space>
void LinearizeFeature(const BasicObservationChunk<typename Space::Observation>& chunk,
                      int64_t feature_slot, const std::vector<typename Space::Pose>& poses,
                      const typename Space::Point& feature, const UnknownLayout& layout,
                      const RobustKernel& kernel, BasicLinearizedFeature<Space>* out) {
  constexpr int P = Space::kPoseDim;
  constexpr int D = Space::kFeatureDim;
  using FeatureMatrix = Eigen::Matrix<double, D, D>;
  FeatureBlocks& blocks = out->blocks;
  blocks.feature_information.setZero(D, D);
  blocks.feature_gradient.setZero(D);
  blocks.poses.clear();
  size_t used = 0;  // slots in use; vectors keep their capacity across features
  out->chi2 = 0.0;
  out->degenerate_observations = 0;

  Eigen::Matrix<double, D, 1> residual;
  Eigen::Matrix<double, D, P> jacobian_pose;
  FeatureMatrix jacobian_feature;
  const int64_t begin = chunk.feature_begin[feature_slot];
  const int64_t end = chunk.feature_begin[feature_slot + 1];
  for (int64_t o = begin; o < end; ++o) {
    const typename Space::Observation& observation = chunk.observations[o];
    if (!Space::Evaluate(observation, poses[observation.pose], feature, &residual,
                         &jacobian_pose, &jacobian_feature)) {
      ++out->degenerate_observations;
      continue;
    }
    const double squared = residual.dot(observation.information * residual);
    out->chi2 += kernel.Cost(squared);
    const FeatureMatrix w = kernel.Weight(squared) * observation.information;
    const FeatureMatrix fw = jacobian_feature.transpose() * w;
    blocks.feature_information += fw * jacobian_feature;
    blocks.feature_gradient += fw * residual;

    const int32_t unknown = layout.unknown_index[observation.pose];
    if (unknown < 0) continue;
    size_t slot = 0;
    while (slot < used && blocks.poses[slot] != unknown) ++slot;
    if (slot == used) {
      blocks.poses.push_back(unknown);
      if (blocks.pose_feature.size() <= used) blocks.pose_feature.emplace_back();
      if (out->pose_hessian.size() <= used) {
        out->pose_hessian.emplace_back();
        out->pose_gradient.emplace_back();
      }
      blocks.pose_feature[slot].setZero(P, D);
      out->pose_hessian[slot].setZero();
      out->pose_gradient[slot].setZero();
      ++used;
    }
    const Eigen::Matrix<double, P, D> aw = jacobian_pose.transpose() * w;
    blocks.pose_feature[slot] += aw * jacobian_feature;
    out->pose_hessian[slot] += aw * jacobian_pose;
    out->pose_gradient[slot] += aw * residual;
  }
  // Slots past `used` are stale entries of an earlier feature.
  blocks.pose_feature.resize(used);
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
                                        LinearizedFeature*);
template void LinearizeFeature<Space3d>(const ObservationChunk3d&, int64_t,
                                        const std::vector<Pose3>&, const Point3&,
                                        const UnknownLayout&, const RobustKernel&,
                                        LinearizedFeature3d*);
template double FeatureChi2<Space2d>(const ObservationChunk&, int64_t, const std::vector<Pose2>&,
                                     const Point2&, const RobustKernel&);
template double FeatureChi2<Space3d>(const ObservationChunk3d&, int64_t,
                                     const std::vector<Pose3>&, const Point3&,
                                     const RobustKernel&);

}  // namespace graphslam::core
