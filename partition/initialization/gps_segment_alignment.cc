#include "partition/initialization/gps_segment_alignment.h"

#include <cmath>
#include <vector>

#include "core/check.h"
#include "core/se2.h"

namespace graphslam::partition {

GpsAlignmentSummary AlignOdometryToGps(core::Problem2d* problem, double min_displacement) {
  GS_CHECK(problem != nullptr);
  GpsAlignmentSummary summary;
  const int32_t n = problem->num_poses();
  if (n < 2) return summary;
  // linked[i]: an odometry constraint joins i and i + 1.
  std::vector<uint8_t> linked(n, 0);
  auto link = [&](int32_t from, int32_t to) {
    if (from >= 0 && to >= 0 && from < n && to < n && std::abs(from - to) == 1)
      linked[std::min(from, to)] = 1;
  };
  for (const core::RelativePoseConstraint& c : problem->relative_poses) link(c.from, c.to);
  for (const core::VelocityMotionConstraint& c : problem->motions) link(c.from, c.to);
  std::vector<int32_t> gps_of(n, -1);  // index into problem->gps of the pose's first fix
  for (int32_t k = 0; k < static_cast<int32_t>(problem->gps.size()); ++k) {
    const int32_t pose = problem->gps[k].pose;
    if (pose >= 0 && pose < n && gps_of[pose] < 0) gps_of[pose] = k;
  }

  const std::vector<core::Pose2> dead_reckoned = problem->poses;
  for (int32_t s = 0; s < n;) {
    int32_t e = s;
    while (e + 1 < n && linked[e] != 0) ++e;
    std::vector<int32_t> fixes;
    bool has_fixed_pose = false;
    for (int32_t i = s; i <= e; ++i) {
      if (gps_of[i] >= 0) fixes.push_back(i);
      if (problem->pose_fixed[i] != 0) has_fixed_pose = true;
    }
    if (fixes.size() >= 2 && !has_fixed_pose) {
      // Corrections per pair; `own[k]` false where the pair was too short.
      const size_t pairs = fixes.size() - 1;
      std::vector<core::Pose2> correction(pairs);
      std::vector<uint8_t> own(pairs, 0);
      for (size_t k = 0; k < pairs; ++k) {
        const core::Pose2& xa = dead_reckoned[fixes[k]];
        const core::Pose2& xb = dead_reckoned[fixes[k + 1]];
        const Eigen::Vector2d d =
            core::Rotation2(-xa.z()) * (xb.head<2>() - xa.head<2>());
        const Eigen::Vector2d za = problem->gps[gps_of[fixes[k]]].z;
        const Eigen::Vector2d big_d = problem->gps[gps_of[fixes[k + 1]]].z - za;
        if (d.norm() < min_displacement || big_d.norm() < min_displacement) continue;
        const double heading = std::atan2(big_d.y(), big_d.x()) - std::atan2(d.y(), d.x());
        correction[k] = core::Compose(core::Pose2(za.x(), za.y(), heading), core::Inverse(xa));
        own[k] = 1;
      }
      // Short pairs borrow the previous correction, leading ones the next.
      int64_t first_own = -1;
      for (size_t k = 0; k < pairs; ++k) {
        if (own[k] != 0) {
          if (first_own < 0) first_own = static_cast<int64_t>(k);
          ++summary.segments;
        }
      }
      if (first_own >= 0) {
        for (size_t k = 0; k < pairs; ++k) {
          if (own[k] != 0) continue;
          correction[k] = k < static_cast<size_t>(first_own) ? correction[first_own]
                                                              : correction[k - 1];
        }
        // Pose i takes the pair whose range [g_k, g_{k+1}) holds it (the
        // first pair before g_0, the last from g_m on).
        size_t k = 0;
        for (int32_t i = s; i <= e; ++i) {
          while (k + 1 < pairs && i >= fixes[k + 1]) ++k;
          problem->poses[i] = core::Compose(correction[k], dead_reckoned[i]);
          problem->poses[i].z() = core::WrapAngle(problem->poses[i].z());
          ++summary.poses_moved;
        }
        ++summary.chains;
      }
    }
    s = e + 1;
  }
  return summary;
}

}  // namespace graphslam::partition
