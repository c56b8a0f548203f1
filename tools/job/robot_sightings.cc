#include "tools/job/robot_sightings.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace graphslam::tools::job {
namespace {

// The pose of [first, first + count) nearest to t, or -1 when it is farther
// than max_difference.
int32_t NearestPose(const std::vector<double>& stamps, int32_t first, int32_t count, double t,
                    double max_difference) {
  const auto begin = stamps.begin() + first;
  const auto end = begin + count;
  const auto upper = std::lower_bound(begin, end, t);
  int32_t best = -1;
  double best_difference = std::numeric_limits<double>::infinity();
  if (upper != end) {
    best = static_cast<int32_t>(upper - stamps.begin());
    best_difference = *upper - t;
  }
  if (upper != begin && t - *std::prev(upper) <= best_difference) {
    best = static_cast<int32_t>(std::prev(upper) - stamps.begin());
    best_difference = t - *std::prev(upper);
  }
  return best_difference <= max_difference ? best : -1;
}

}  // namespace

SightingCounts AddRobotSightings(const std::vector<RunSightings>& runs,
                                 double max_time_difference, core::Problem2d* problem) {
  SightingCounts counts;
  for (const RunSightings& observer : runs) {
    if (observer.dataset.empty()) continue;
    for (const storage::MrclamRobotSighting& sighting : observer.sightings) {
      const RunSightings* observed = nullptr;
      for (const RunSightings& other : runs)
        if (other.dataset == observer.dataset && other.robot == sighting.observed_robot &&
            &other != &observer)
          observed = &other;
      if (observed == nullptr) {
        ++counts.robot_not_in_job;
        continue;
      }
      const int32_t from = NearestPose(problem->pose_stamps, observer.first_pose,
                                       observer.num_poses, sighting.stamp, max_time_difference);
      const int32_t to = NearestPose(problem->pose_stamps, observed->first_pose,
                                     observed->num_poses, sighting.stamp, max_time_difference);
      if (from < 0 || to < 0) {
        ++counts.no_pose_at_stamp;
        continue;
      }
      core::PoseRangeBearingConstraint constraint;
      constraint.from = from;
      constraint.to = to;
      constraint.z = sighting.z;
      constraint.information = observer.information;
      constraint.line = sighting.line;
      problem->pose_range_bearings.push_back(constraint);
      ++counts.constraints;
    }
  }
  return counts;
}

std::map<std::pair<int32_t, int32_t>, int64_t> CountSightingsPerRunPair(
    const core::Problem2d& problem, const std::vector<int32_t>& run_of_pose) {
  std::map<std::pair<int32_t, int32_t>, int64_t> counts;
  for (const core::PoseRangeBearingConstraint& c : problem.pose_range_bearings) {
    const int32_t a = run_of_pose[static_cast<size_t>(c.from)];
    const int32_t b = run_of_pose[static_cast<size_t>(c.to)];
    ++counts[{std::min(a, b), std::max(a, b)}];
  }
  return counts;
}

}  // namespace graphslam::tools::job
