// Robot-to-robot constraints of a job: robots of one MRCLAM dataset drive at
// the same time, and a measurement of another robot's barcode ties the two
// runs (core/pose_range_bearing_model.h).
//
// A sighting (stamp t, observed robot j, z = (range, bearing)) read from run
// A's measurements (storage::MrclamRobotSighting) becomes the constraint
//   from = A's pose nearest to t (within max_time_difference, else dropped),
//   z, information = A's measurement information,
// where B is the job's run of robot j of the SAME dataset folder, and B's
// position at t is
//   - B's pose at t itself (stamp within 1e-9 s): to = that pose, the
//     two-pose constraint of core/pose_range_bearing_model.h;
//   - else, when t lies between two consecutive poses of B at t0 < t < t1
//     with t1 - t0 <= max_interpolation_gap: to = the pose at t0, to_next =
//     the pose at t1, alpha = (t - t0) / (t1 - t0), the three-pose constraint
//     of core/interpolated_pose_range_bearing_model.h (counted as
//     `interpolated`);
//   - else (t before B's first or after its last pose, or in a longer gap)
//     the sighting is dropped and counted.
// MRCLAM's 50 Hz files put every robot on one 0.02 s grid starting at 0 and
// the measurements on that grid too, so both poses are at t itself and no
// sighting is interpolated; B's poses on another grid (raw stamps, thinned
// poses, another rate) are interpolated instead of snapped to the nearest
// pose, which is up to half a gap of B's motion off. The observer's pose is
// still the nearest: with irregular raw stamps, 0.02 s at the robots' speeds
// (< 0.5 m/s) is at most 1 cm of motion, a tenth of the range noise. A
// sighting of a robot that is no run of the job is counted and dropped.
//
// Standstill repeats: while BOTH robots stand still (every control between
// the poses, as the motions carry them, below storage::MrclamStandsStill), the
// camera reads the same sighting again and again with the same error: in
// dataset 1 robot 3 reads robot 4 244 times in 1420-1500 s, 0.20 m long
// every time (Vicon). As in storage/mrclam_reader.h, all sightings of one
// observer's standstill of one observed robot's standstill become ONE
// constraint, z = their mean (circular in the bearing), at the first
// sighting's poses, with the information of one reading. (An interpolated
// sighting merges only with others between poses of the same standstills.)
//
// THREAD SAFETY: pure functions. ALLOCATION: O(sightings + runs).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "core/problem.h"
#include "storage/mrclam_reader.h"

namespace graphslam::tools::job {

// The sightings one run read, and where its poses are in the merged problem.
struct RunSightings {
  std::string dataset;  // the MRCLAM folder (canonical); empty: not an MRCLAM run
  int robot = 0;        // 1..5
  int32_t first_pose = 0;
  int32_t num_poses = 0;
  Eigen::Matrix2d information = Eigen::Matrix2d::Identity();
  std::vector<storage::MrclamRobotSighting> sightings;
};

struct SightingCounts {
  int64_t constraints = 0;       // became pose_range_bearings
  int64_t interpolated = 0;      // of those, B's position between two poses
  int64_t robot_not_in_job = 0;  // the observed robot is no run of the job
  int64_t no_pose_at_stamp = 0;  // no pose of A near t, or t not within B's poses
  int64_t standstill_repeats_merged = 0;  // merged into an earlier constraint
};

inline constexpr double kDefaultSightingMaxTimeDifference = 0.02;  // s
// The longest gap between two poses of B to interpolate in: at most 0.016 m
// between the chord and the arc at 0.5 m/s and 1 rad/s
// (core/interpolated_pose_range_bearing_model.h).
inline constexpr double kDefaultSightingMaxInterpolationGap = 0.5;  // s

// Appends the constraints of every run's sightings to
// problem->pose_range_bearings (pose stamps from problem->pose_stamps, each
// run's in non-decreasing order; standstills from problem->motions).
SightingCounts AddRobotSightings(const std::vector<RunSightings>& runs,
                                 double max_time_difference, double max_interpolation_gap,
                                 core::Problem2d* problem);

// How many pose_range_bearings tie each pair of runs (a < b, either
// direction); `run_of_pose` gives each pose's run.
std::map<std::pair<int32_t, int32_t>, int64_t> CountSightingsPerRunPair(
    const core::Problem2d& problem, const std::vector<int32_t>& run_of_pose);

}  // namespace graphslam::tools::job
