#include "core/feature_linearizer.h"

#include "core/point_observation_model.h"
#include "core/range_bearing_model.h"

namespace graphslam::core {
namespace {

// Residual and Jacobians of one observation; false if degenerate.
bool EvaluateObservation(const Observation& observation, const Pose2& pose, const Point2& feature,
                         Eigen::Vector2d* residual, Eigen::Matrix<double, 2, 3>* jacobian_pose,
                         Eigen::Matrix2d* jacobian_feature) {
  switch (observation.kind) {
    case ObservationKind::kRangeBearing:
      return EvaluateRangeBearing(pose, feature, observation.z, residual, jacobian_pose,
                                  jacobian_feature);
    case ObservationKind::kPointXY:
      EvaluatePointObservation(pose, feature, observation.z, residual, jacobian_pose,
                               jacobian_feature);
      return true;
  }
  return false;
}

}  // namespace

void LinearizeFeature(const ObservationChunk& chunk, int64_t feature_slot,
                      const std::vector<Pose2>& poses, const Point2& feature,
                      const UnknownLayout& layout, const RobustKernel& kernel,
                      LinearizedFeature* out) {
  FeatureBlocks& blocks = out->blocks;
  blocks.feature_information.setZero(2, 2);
  blocks.feature_gradient.setZero(2);
  blocks.poses.clear();
  size_t used = 0;  // slots in use; vectors keep their capacity across features
  out->chi2 = 0.0;
  out->degenerate_observations = 0;

  Eigen::Vector2d residual;
  Eigen::Matrix<double, 2, 3> jacobian_pose;
  Eigen::Matrix2d jacobian_feature;
  const int64_t begin = chunk.feature_begin[feature_slot];
  const int64_t end = chunk.feature_begin[feature_slot + 1];
  for (int64_t o = begin; o < end; ++o) {
    const Observation& observation = chunk.observations[o];
    if (!EvaluateObservation(observation, poses[observation.pose], feature, &residual,
                             &jacobian_pose, &jacobian_feature)) {
      ++out->degenerate_observations;
      continue;
    }
    const double squared = residual.dot(observation.information * residual);
    out->chi2 += kernel.Cost(squared);
    const Eigen::Matrix2d w = kernel.Weight(squared) * observation.information;
    jacobian_pose = jacobian_pose * RetractionJacobian(poses[observation.pose]);
    const Eigen::Matrix2d fw = jacobian_feature.transpose() * w;
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
      blocks.pose_feature[slot].setZero(3, 2);
      out->pose_hessian[slot].setZero();
      out->pose_gradient[slot].setZero();
      ++used;
    }
    const Eigen::Matrix<double, 3, 2> aw = jacobian_pose.transpose() * w;
    blocks.pose_feature[slot] += aw * jacobian_feature;
    out->pose_hessian[slot] += aw * jacobian_pose;
    out->pose_gradient[slot] += aw * residual;
  }
  // Slots past `used` are stale entries of an earlier feature.
  blocks.pose_feature.resize(used);
}

double FeatureChi2(const ObservationChunk& chunk, int64_t feature_slot,
                   const std::vector<Pose2>& poses, const Point2& feature,
                   const RobustKernel& kernel) {
  double chi2 = 0.0;
  Eigen::Vector2d residual;
  for (int64_t o = chunk.feature_begin[feature_slot]; o < chunk.feature_begin[feature_slot + 1];
       ++o) {
    const Observation& observation = chunk.observations[o];
    if (!EvaluateObservation(observation, poses[observation.pose], feature, &residual, nullptr,
                             nullptr))
      continue;
    chi2 += kernel.Cost(residual.dot(observation.information * residual));
  }
  return chi2;
}

}  // namespace graphslam::core
