// Robot-to-robot constraints of a job: robots of one MRCLAM dataset drive at
// the same time, and a measurement of another robot's barcode ties the two
// runs (core/pose_range_bearing_model.h).
//
// A sighting (stamp t, observed robot j, z = (range, bearing)) read from run
// A's measurements (storage::MrclamRobotSighting) becomes the constraint
//   from = A's pose nearest to t,  to = B's pose nearest to t,
//   z, information = A's measurement information,
// where B is the job's run of robot j of the SAME dataset folder. Both poses
// must lie within max_time_difference of t, else the sighting is dropped and
// counted. MRCLAM's 50 Hz files put every robot on one 0.02 s grid starting
// at 0 and the measurements on that grid too, so both poses are at t itself
// (difference 0) and no interpolation is needed; with irregular raw stamps,
// 0.02 s at the robots' speeds (< 0.5 m/s) is at most 1 cm of motion, a tenth
// of the range noise. A sighting of a robot that is no run of the job is
// counted and dropped.
//
// Standstill repeats: while BOTH robots stand still (every control between
// the poses, as the motions carry them, below storage::MrclamStandsStill), the
// camera reads the same sighting again and again with the same error: in
// dataset 1 robot 3 reads robot 4 244 times in 1420-1500 s, 0.20 m long
// every time (Vicon). As in storage/mrclam_reader.h, all sightings of one
// observer's standstill of one observed robot's standstill become ONE
// constraint, z = their mean (circular in the bearing), at the first
// sighting's poses, with the information of one reading.
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
  int64_t robot_not_in_job = 0;  // the observed robot is no run of the job
  int64_t no_pose_at_stamp = 0;  // a pose farther than max_time_difference from t
  int64_t standstill_repeats_merged = 0;  // merged into an earlier constraint
};

inline constexpr double kDefaultSightingMaxTimeDifference = 0.02;  // s

// Appends the constraints of every run's sightings to
// problem->pose_range_bearings (pose stamps from problem->pose_stamps, each
// run's in non-decreasing order; standstills from problem->motions).
SightingCounts AddRobotSightings(const std::vector<RunSightings>& runs,
                                 double max_time_difference, core::Problem2d* problem);

// How many pose_range_bearings tie each pair of runs (a < b, either
// direction); `run_of_pose` gives each pose's run.
std::map<std::pair<int32_t, int32_t>, int64_t> CountSightingsPerRunPair(
    const core::Problem2d& problem, const std::vector<int32_t>& run_of_pose);

}  // namespace graphslam::tools::job
