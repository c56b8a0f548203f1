#include "partition/association/windowed_stage.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace graphslam::partition {

Status StageWindowOptions::Validate() const {
  if (window_poses < 0 || window_observations < 0 || loop_closure_poses < 0 ||
      max_loop_closure_poses < 0 || max_prior_observations_per_feature < 0)
    return Status::InvalidArgument(
        "incremental association: window_poses, window_observations, loop_closure_poses, "
        "max_loop_closure_poses and max_prior_observations_per_feature must be >= 0, got " +
        std::to_string(window_poses) + ", " + std::to_string(window_observations) + ", " +
        std::to_string(loop_closure_poses) + ", " + std::to_string(max_loop_closure_poses) +
        " and " + std::to_string(max_prior_observations_per_feature));
  if (full_stage_growth != 0.0 && (!(full_stage_growth > 1.0) || !std::isfinite(full_stage_growth)))
    return Status::InvalidArgument(
        "incremental association: full_stage_growth must be 0 (off) or finite and > 1, got " +
        std::to_string(full_stage_growth));
  return Status::Ok();
}

int32_t StageWindows::Begin(int32_t begin, int32_t end) {
  const std::vector<int64_t>& before = observations_before_;
  const int64_t by_poses = static_cast<int64_t>(end) - options_.window_poses;
  // The last pose q with at least window_observations observations in [q, end).
  const int64_t wanted = before[end] - options_.window_observations;
  const int64_t by_observations =
      wanted < 0 ? -1
                 : static_cast<int64_t>(std::upper_bound(before.begin(), before.end(), wanted) -
                                        before.begin()) - 1;
  const int64_t window_begin =
      std::clamp<int64_t>(std::min(by_poses, by_observations), 0, begin);
  const bool full = !options_.enabled || window_begin == 0 ||
                    (options_.full_stage_growth > 0.0 &&
                     static_cast<double>(end) >=
                         options_.full_stage_growth * static_cast<double>(last_whole_));
  if (!full) return static_cast<int32_t>(window_begin);
  last_whole_ = end;
  return 0;
}

WindowedStageBuilder::WindowedStageBuilder(const StageWindowOptions& options,
                                           const core::Problem2d& problem)
    : options_(options), problem_(problem), mark_(problem.poses.size(), 0) {
  internal::BuildPoseIndices(problem, &index_);
}

void WindowedStageBuilder::Build(int32_t window_begin, int32_t new_begin, int32_t end,
                                 const std::vector<core::Pose2>& poses,
                                 const std::vector<int32_t>& label,
                                 const std::vector<core::Point2>& positions,
                                 const std::vector<int32_t>& extra, WindowedSubProblem* out) {
  std::vector<core::Observation> labelled;
  for (size_t o = 0; o < problem_.observations.size(); ++o) {
    const core::Observation& obs = problem_.observations[o];
    if (label[o] < 0 || obs.pose >= end) continue;
    labelled.push_back(obs);
    labelled.back().feature = label[o];
  }
  const auto labels = static_cast<int32_t>(positions.size());
  internal::BuildObservationIndices(end, labels, labelled, &index_);
  internal::StageBuilder<std::vector<core::Observation>> builder(problem_, labelled, index_, labels,
                                                                 nullptr);
  out->unknown_poses =
      internal::UnknownPoses(options_.loop_closure_poses, options_.max_loop_closure_poses, index_,
                             new_begin, window_begin, end, &mark_);
  int64_t constraints = 0;
  out->sub = builder.Build(0, out->unknown_poses, window_begin, end,
                           options_.max_prior_observations_per_feature, poses, positions,
                           &constraints, &extra);
  out->sub.source = problem_.source;
  out->local_of_label.resize(labels);
  for (int32_t l = 0; l < labels; ++l) out->local_of_label[l] = builder.local_feature(l);
  out->local_poses.clear();
  for (int32_t p : out->unknown_poses) out->local_poses.push_back(builder.local_pose(p));
}

}  // namespace graphslam::partition
