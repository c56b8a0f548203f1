#include "tools/job/robot_sightings.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>
#include <utility>

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

// Where run [first, first + count) was at t: its pose at t itself (within
// kSameInstant; *next = -1), else the poses before and after t when they are
// at most max_gap apart (*next >= 0, *alpha in (0, 1)), else -1.
constexpr double kSameInstant = 1e-9;  // s

int32_t ObservedPose(const std::vector<double>& stamps, int32_t first, int32_t count, double t,
                     double max_gap, int32_t* next, double* alpha) {
  *next = -1;
  *alpha = 0.0;
  const int32_t at = NearestPose(stamps, first, count, t, kSameInstant);
  if (at >= 0) return at;
  const auto begin = stamps.begin() + first;
  const auto end = begin + count;
  const auto after = std::upper_bound(begin, end, t);
  if (after == begin || after == end) return -1;  // before the first or after the last pose
  const double t0 = *std::prev(after), t1 = *after;
  if (!(t1 - t0 <= max_gap)) return -1;
  *next = static_cast<int32_t>(after - stamps.begin());
  *alpha = (t - t0) / (t1 - t0);
  return *next - 1;
}

// standstill[p]: the first pose of the standstill that pose p is in (p itself
// when the control into p moves the robot); motions with to = from + 1 whose
// control does not move the robot (storage::MrclamStandsStill) join one.
std::vector<int32_t> StandstillOfPose(const core::Problem2d& problem) {
  std::vector<int32_t> standstill(static_cast<size_t>(problem.num_poses()));
  for (int32_t p = 0; p < problem.num_poses(); ++p) standstill[static_cast<size_t>(p)] = p;
  for (const core::VelocityMotionConstraint& motion : problem.motions)
    if (motion.to == motion.from + 1 &&
        storage::MrclamStandsStill(motion.control.v, motion.control.omega))
      standstill[static_cast<size_t>(motion.to)] = standstill[static_cast<size_t>(motion.from)];
  return standstill;
}

}  // namespace

SightingCounts AddRobotSightings(const std::vector<RunSightings>& runs,
                                 double max_time_difference, double max_interpolation_gap,
                                 core::Problem2d* problem) {
  SightingCounts counts;
  // Motions are appended in pose order, so one pass suffices.
  const std::vector<int32_t> standstill = StandstillOfPose(*problem);
  // (standstill of from, standstill of to, standstill of to_next or of to)
  // -> the constraint of those; per constraint the sums of (range, cos
  // bearing, sin bearing) and the count.
  std::map<std::tuple<int32_t, int32_t, int32_t>, size_t> merged_into;
  std::vector<Eigen::Vector3d> sums;
  std::vector<int32_t> repeats;
  const size_t first_new = problem->pose_range_bearings.size();
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
      int32_t to_next = -1;
      double alpha = 0.0;
      const int32_t to =
          ObservedPose(problem->pose_stamps, observed->first_pose, observed->num_poses,
                       sighting.stamp, max_interpolation_gap, &to_next, &alpha);
      if (from < 0 || to < 0) {
        ++counts.no_pose_at_stamp;
        continue;
      }
      const Eigen::Vector3d sum(sighting.z.x(), std::cos(sighting.z.y()),
                                std::sin(sighting.z.y()));
      const auto [group, inserted] = merged_into.try_emplace(
          {standstill[static_cast<size_t>(from)], standstill[static_cast<size_t>(to)],
           standstill[static_cast<size_t>(to_next >= 0 ? to_next : to)]},
          sums.size());
      if (!inserted) {
        sums[group->second] += sum;
        ++repeats[group->second];
        ++counts.standstill_repeats_merged;
        continue;
      }
      sums.push_back(sum);
      repeats.push_back(1);
      core::PoseRangeBearingConstraint constraint;
      constraint.from = from;
      constraint.to = to;
      constraint.z = sighting.z;
      constraint.information = sighting.information;
      constraint.line = sighting.line;
      constraint.to_next = to_next;
      constraint.alpha = alpha;
      problem->pose_range_bearings.push_back(constraint);
      ++counts.constraints;
      if (to_next >= 0) ++counts.interpolated;
    }
  }
  for (size_t i = 0; i < sums.size(); ++i) {
    if (repeats[i] < 2) continue;
    problem->pose_range_bearings[first_new + i].z =
        Eigen::Vector2d(sums[i].x() / repeats[i], std::atan2(sums[i].z(), sums[i].y()));
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
