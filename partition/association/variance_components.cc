#include "partition/association/variance_components.h"

#include <string>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/gps_model.h"
#include "core/pose_factors.h"
#include "core/problem_space.h"
#include "core/se2.h"
#include "core/unknown_layout.h"

namespace graphslam::partition {
namespace {

struct Sums {
  double chi2 = 0.0;
  double redundancy = 0.0;
  int64_t residuals = 0;
};

void SetFactor(double min_redundancy, VarianceComponent* c) {
  c->factor = (c->redundancy >= min_redundancy && c->redundancy > 0.0 && c->chi2 >= 0.0)
                  ? c->chi2 / c->redundancy
                  : 1.0;
}

// tr(Omega (y^T y + own)) for a whitened G.
double Leverage(const Eigen::Matrix2d& information, const core::PoseMarginals::WhitenedColumns& y,
                const Eigen::Matrix2d& own) {
  return (information * (core::PoseMarginals::Dot(y, y) + own)).trace();
}

}  // namespace

Status EstimateVarianceComponents(const core::Problem2d& problem,
                                  const core::PoseMarginals& marginals,
                                  const std::vector<FeatureState>& states,
                                  const core::RobustKernel& observation_kernel,
                                  double min_redundancy, VarianceComponents* out) {
  *out = VarianceComponents();
  if (states.size() != problem.features.size())
    return Status::InvalidArgument("variance components: " + std::to_string(states.size()) +
                                   " feature states for " +
                                   std::to_string(problem.features.size()) + " features");
  const core::UnknownLayout layout = core::UnknownLayout::FromProblem(problem);
  const auto m = static_cast<int64_t>(problem.observations.size());

  // Observations: chi2 and redundancy number of each, in parallel, then
  // summed in order (the same bits on every run and thread count).
  std::vector<Status> errors(static_cast<size_t>(m));
  std::vector<double> chi2(static_cast<size_t>(m), 0.0);
  std::vector<double> redundancy(static_cast<size_t>(m), 0.0);
  std::vector<uint8_t> counted(static_cast<size_t>(m), 0);
  tbb::enumerable_thread_specific<core::PoseMarginals::WhitenWorkspace> workspaces;
  tbb::parallel_for(tbb::blocked_range<int64_t>(0, m, 256), [&](const tbb::blocked_range<int64_t>&
                                                                    range) {
    core::PoseMarginals::WhitenWorkspace& workspace = workspaces.local();
    std::vector<int32_t> blocks;
    std::vector<Eigen::Matrix<double, 3, 2>> values;
    core::PoseMarginals::WhitenedColumns y;
    for (int64_t i = range.begin(); i != range.end(); ++i) {
      const core::Observation& o = problem.observations[i];
      if (o.feature < 0 || static_cast<size_t>(o.feature) >= states.size() ||
          !states[o.feature].usable)
        continue;
      const FeatureState& state = states[o.feature];
      Eigen::Vector2d e;
      Eigen::Matrix<double, 2, 3> a_pose;
      Eigen::Matrix2d a_feature;
      // Space2d::Evaluate: the pose Jacobian w.r.t. the solver's increment.
      if (!core::Space2d::Evaluate(o, problem.poses[o.pose], problem.features[o.feature], &e,
                                   &a_pose, &a_feature))
        continue;
      blocks.clear();
      values.clear();
      const int32_t pose_block = layout.unknown_index[o.pose];
      if (pose_block >= 0) {
        blocks.push_back(pose_block);
        values.emplace_back(a_pose.transpose());
      }
      for (size_t k = 0; k < state.gain.blocks.size(); ++k) {
        blocks.push_back(state.gain.blocks[k]);
        values.emplace_back(state.gain.gains[k] * a_feature.transpose());
      }
      const Eigen::Matrix2d own = a_feature * state.gain.own_covariance * a_feature.transpose();
      if (blocks.empty()) {
        y = core::PoseMarginals::WhitenedColumns();
      } else {
        errors[i] = marginals.Whiten(blocks, values, &y, &workspace);
        if (!errors[i].ok()) continue;
      }
      // The IRLS weight the linearization gave this observation.
      const double squared = e.dot(o.information * e);
      const double weight = observation_kernel.Weight(squared);
      chi2[i] = weight * squared;
      redundancy[i] = 2.0 - weight * Leverage(o.information, y, own);
      counted[i] = 1;
    }
  });
  for (const Status& error : errors) GS_RETURN_IF_ERROR(error);
  Sums obs;
  for (int64_t i = 0; i < m; ++i) {
    if (!counted[i]) continue;
    obs.chi2 += chi2[i];
    obs.redundancy += redundancy[i];
    obs.residuals += 2;
  }
  int64_t feature_unknowns = 0;
  {
    std::vector<uint8_t> seen(states.size(), 0);
    for (const core::Observation& o : problem.observations)
      if (o.feature >= 0 && static_cast<size_t>(o.feature) < states.size() &&
          states[o.feature].usable && !seen[o.feature]) {
        seen[o.feature] = 1;
        feature_unknowns += 2;
      }
  }

  // GPS fixes: G = E_p J^T.
  Sums gps;
  core::PoseMarginals::WhitenWorkspace workspace;
  for (const core::GpsConstraint& c : problem.gps) {
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 3> jacobian;
    core::EvaluateGps(problem.poses[c.pose], c.z, &e, &jacobian);
    jacobian = jacobian * core::RetractionJacobian(problem.poses[c.pose]);
    core::PoseMarginals::WhitenedColumns y;
    const int32_t block = layout.unknown_index[c.pose];
    if (block >= 0)
      GS_RETURN_IF_ERROR(marginals.Whiten({block}, {jacobian.transpose()}, &y, &workspace));
    gps.chi2 += e.dot(c.information * e);
    gps.redundancy += 2.0 - Leverage(c.information, y, Eigen::Matrix2d::Zero());
    gps.residuals += 2;
  }

  // Pose constraints: the rest of the total redundancy m - n.
  Sums pose;
  pose.residuals = 3 * static_cast<int64_t>(problem.relative_poses.size() +
                                            problem.motions.size()) +
                   2 * static_cast<int64_t>(problem.pose_range_bearings.size());
  pose.chi2 = core::PoseFactorsChi2(problem, problem.poses) - gps.chi2;
  const int64_t unknowns =
      int64_t{core::UnknownLayout::kPoseDimension} * layout.num_unknown_poses + feature_unknowns;
  const int64_t total_redundancy = obs.residuals + gps.residuals + pose.residuals - unknowns;
  pose.redundancy = static_cast<double>(total_redundancy) - obs.redundancy - gps.redundancy;

  auto fill = [&](const Sums& sums, VarianceComponent* c) {
    c->residuals = sums.residuals;
    c->chi2 = sums.chi2;
    c->redundancy = sums.redundancy;
    SetFactor(min_redundancy, c);
  };
  fill(obs, &out->observations);
  fill(gps, &out->gps);
  fill(pose, &out->pose_constraints);
  return Status::Ok();
}

}  // namespace graphslam::partition
