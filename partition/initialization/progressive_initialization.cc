#include "partition/initialization/progressive_initialization.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <utility>

#include "core/logging.h"
#include "core/point_observation_model.h"
#include "core/range_bearing_model.h"
#include "core/se2.h"
#include "core/velocity_motion_model.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/initialization/internal/odometry_chain.h"
#include "partition/initialization/internal/stage_growth.h"
#include "partition/initialization/internal/stage_setup.h"
#include "partition/initialization/singleton_solve.h"

namespace graphslam::partition {
namespace {

using core::Point2;
using core::Pose2;

std::string Prefix(const core::Problem2d& problem) {
  return (problem.source.empty() ? std::string("<input>") : problem.source) + ": ";
}

Status CheckIndex(const core::Problem2d& problem, int32_t index, int32_t size, int32_t line,
                  const char* what) {
  if (index >= 0 && index < size) return Status::Ok();
  std::string message = Prefix(problem);
  if (line > 0) message += "line " + std::to_string(line) + ": ";
  return Status::InvalidArgument(message + what + " index " + std::to_string(index) +
                                 " out of range, expected 0.." + std::to_string(size - 1));
}

Status CheckIndices(const core::Problem2d& problem) {
  const int32_t n = problem.num_poses(), m = problem.num_features();
  GS_RETURN_IF_ERROR(internal::CheckPerElementArrays(problem));
  for (const core::RelativePoseConstraint& c : problem.relative_poses) {
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.from, n, c.line, "relative pose 'from' pose"));
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.to, n, c.line, "relative pose 'to' pose"));
  }
  for (const core::VelocityMotionConstraint& c : problem.motions) {
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.from, n, c.line, "motion 'from' pose"));
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.to, n, c.line, "motion 'to' pose"));
  }
  for (const core::GpsConstraint& c : problem.gps)
    GS_RETURN_IF_ERROR(CheckIndex(problem, c.pose, n, c.line, "GPS pose"));
  for (const core::Observation& o : problem.observations) {
    GS_RETURN_IF_ERROR(CheckIndex(problem, o.pose, n, o.line, "observation pose"));
    GS_RETURN_IF_ERROR(CheckIndex(problem, o.feature, m, o.line, "observation feature"));
  }
  return Status::Ok();
}

// The sub-problem of the first `t` poses; local_feature[f] receives the index
// of global feature f in it (-1 when not observed from the prefix).
core::Problem2d BuildPrefix(const core::Problem2d& problem, const std::vector<Pose2>& poses,
                            const std::vector<Point2>& features, int32_t t,
                            std::vector<int32_t>* local_feature) {
  core::Problem2d sub;
  sub.source = problem.source;
  sub.poses.assign(poses.begin(), poses.begin() + t);
  sub.pose_ids.assign(problem.pose_ids.begin(), problem.pose_ids.begin() + t);
  sub.pose_fixed.assign(problem.pose_fixed.begin(), problem.pose_fixed.begin() + t);
  sub.pose_initialized.assign(t, 1);
  sub.pose_lines.assign(problem.pose_lines.begin(), problem.pose_lines.begin() + t);
  sub.pose_stamps.assign(problem.pose_stamps.begin(), problem.pose_stamps.begin() + t);

  local_feature->assign(problem.features.size(), -1);
  for (const core::Observation& o : problem.observations)
    if (o.pose < t) (*local_feature)[o.feature] = 0;
  for (int32_t f = 0; f < problem.num_features(); ++f) {
    if ((*local_feature)[f] < 0) continue;
    (*local_feature)[f] = sub.AddFeature(problem.feature_ids[f], features[f], true);
  }
  for (const core::RelativePoseConstraint& c : problem.relative_poses)
    if (c.from < t && c.to < t) sub.relative_poses.push_back(c);
  for (const core::VelocityMotionConstraint& c : problem.motions)
    if (c.from < t && c.to < t) sub.motions.push_back(c);
  for (const core::GpsConstraint& c : problem.gps)
    if (c.pose < t) sub.gps.push_back(c);
  for (const core::PoseRangeBearingConstraint& c : problem.pose_range_bearings)
    if (c.from < t && c.to < t && c.to_next < t) sub.pose_range_bearings.push_back(c);
  for (const core::Observation& o : problem.observations) {
    if (o.pose >= t) continue;
    sub.observations.push_back(o);
    sub.observations.back().feature = (*local_feature)[o.feature];
  }
  return sub;
}

Status SolvePass(const core::SolverOptions& options, const ChunkingOptions& chunking,
                 core::Problem2d* sub, core::SolverSummary* summary) {
  // Features seen once so far (every feature of an id-less input) are left
  // out and placed from their observation: exact, and kept in they spoil the
  // steps (partition/initialization/singleton_solve.h).
  return SolveWithoutSingletons(options, chunking, sub, summary);
}

}  // namespace

Status ProgressiveInitializationOptions::Validate() const {
  if (first_poses < 1)
    return Status::InvalidArgument("progressive initialization: first_poses must be >= 1, got " +
                                   std::to_string(first_poses));
  if (!(growth > 1.0) || !std::isfinite(growth))
    return Status::InvalidArgument("progressive initialization: growth must be finite and > 1, got " +
                                   std::to_string(growth));
  if (max_new_poses < 0)
    return Status::InvalidArgument(
        "progressive initialization: max_new_poses must be >= 0 (0: no cap), got " +
        std::to_string(max_new_poses));
  if (min_new_poses < 1)
    return Status::InvalidArgument("progressive initialization: min_new_poses must be >= 1, got " +
                                   std::to_string(min_new_poses));
  if (max_iterations_per_stage < 0)
    return Status::InvalidArgument(
        "progressive initialization: max_iterations_per_stage must be >= 0, got " +
        std::to_string(max_iterations_per_stage));
  if (max_observations_per_chunk < 1)
    return Status::InvalidArgument(
        "progressive initialization: max_observations_per_chunk must be >= 1, got " +
        std::to_string(max_observations_per_chunk));
  return Status::Ok();
}

Status InitializeProgressively(const ProgressiveInitializationOptions& options,
                               const core::SolverOptions& base, core::Problem2d* problem,
                               ProgressiveSummary* summary) {
  GS_ASSIGN_OR_RETURN(const bool has_stages,
                      BeginPrefixStages(options, base, *problem, summary, CheckIndices));
  if (!has_stages) return Status::Ok();
  const StageClock::time_point start = StageClock::now();
  const int32_t n = problem->num_poses();

  // Working copies: *problem changes only at the end, when every stage succeeded.
  std::vector<Pose2> poses = problem->poses;
  std::vector<Point2> features = problem->features;
  std::vector<uint8_t> placed(n, 0);
  for (int32_t p = 0; p < n; ++p) placed[p] = problem->pose_fixed[p] != 0;  // anchors stay put

  const std::vector<std::vector<internal::PoseEdge>> adjacency = internal::OdometryAdjacency(*problem);
  // First sighting of each feature: lowest pose index, then input order.
  std::vector<int64_t> first_sight(problem->features.size(), -1);
  for (size_t k = 0; k < problem->observations.size(); ++k) {
    const core::Observation& o = problem->observations[k];
    int64_t& first = first_sight[o.feature];
    if (first < 0 || o.pose < problem->observations[first].pose) first = static_cast<int64_t>(k);
  }

  ChunkingOptions chunking;
  chunking.max_observations_per_chunk = options.max_observations_per_chunk;
  const core::SolverOptions stage_options =
      internal::StageSolverOptions(base, options.max_iterations_per_stage);

  // New poses a stage may add: max_new_poses, halved after a stage that did
  // not converge in its iterations (its chained segment was too far from the
  // optimum: dead-reckoning drift grows with the segment), doubled back after
  // one that did (header).
  int64_t allowed = options.max_new_poses;
  int32_t previous = 0;
  int32_t t = static_cast<int32_t>(std::min<int64_t>(options.first_poses, n));
  for (size_t stage = 0;; ++stage) {
    if (stage > 0) t = internal::NextStageSize(options.growth, allowed, previous, n);
    const StageClock::time_point stage_start = StageClock::now();
    if (stage == 0) {
      for (int32_t p = 0; p < t; ++p) placed[p] = 1;  // the input guess
    } else {
      internal::PlacePoses(*problem, adjacency, previous, t, &poses, &placed);
    }
    for (size_t f = 0; f < first_sight.size(); ++f) {
      if (first_sight[f] < 0) continue;
      const core::Observation& o = problem->observations[first_sight[f]];
      if (o.pose < previous || o.pose >= t) continue;
      features[f] = core::InvertObservation(o.kind, poses[o.pose], o.z);
    }
    previous = t;
    if (t == n && !options.solve_last_stage) break;

    std::vector<int32_t> local_feature;
    core::Problem2d sub = BuildPrefix(*problem, poses, features, t, &local_feature);
    ProgressiveStageSummary stage_summary;
    stage_summary.poses = t;
    stage_summary.features = sub.num_features();
    stage_summary.observations = static_cast<int64_t>(sub.observations.size());
    core::SolverSummary solver_summary;
    const std::string context = "progressive initialization stage " + std::to_string(stage) +
                                " (" + std::to_string(t) + " poses)";
    Status status = SolvePass(stage_options, chunking, &sub, &solver_summary);
    if (!status.ok()) return status.WithContext(context);
    stage_summary.initial_chi2 = solver_summary.initial_chi2;
    stage_summary.final_chi2 = solver_summary.final_chi2;
    stage_summary.iterations = solver_summary.iterations;
    stage_summary.termination = solver_summary.termination;

    std::copy(sub.poses.begin(), sub.poses.end(), poses.begin());
    for (size_t f = 0; f < local_feature.size(); ++f)
      if (local_feature[f] >= 0) features[f] = sub.features[local_feature[f]];
    stage_summary.seconds = StageSecondsSince(stage_start);
    GS_VLOG(1, "progressive initialization: stage %zu, %d poses, %lld features, chi2 %.6g -> %.6g "
               "in %d iterations (%s), %.3f s",
            stage, t, static_cast<long long>(stage_summary.features), stage_summary.initial_chi2,
            stage_summary.final_chi2, stage_summary.iterations, stage_summary.termination.c_str(),
            stage_summary.seconds);
    summary->stages.push_back(std::move(stage_summary));
    if (base.progress) base.progress("progressive initialization", t, n);
    if (t == n) break;
    if (options.max_new_poses > 0 && options.max_iterations_per_stage > 0) {
      // Unsettled: stopped by the iteration cap while its last iteration still
      // lowered chi2 by more than 1 % (far from the stage optimum, not merely
      // short of the tight function tolerance).
      allowed = internal::NextAllowedNewPoses(solver_summary, allowed, options.min_new_poses,
                                              options.max_new_poses);
    }
  }

  problem->poses = std::move(poses);
  problem->features = std::move(features);
  for (size_t f = 0; f < first_sight.size(); ++f)
    if (first_sight[f] >= 0) problem->feature_initialized[f] = 1;
  summary->seconds = StageSecondsSince(start);
  return Status::Ok();
}

}  // namespace graphslam::partition
