// Scans for the `simulate` runs of a job: the 2-D simulated campus
// (tools/campus_simulator.h) seen by a vertically scanning laser, as the
// paper's robot builds its 3-D map while it drives.
//
// World (metres, z up), consistent with the 2-D campus: streets are the grid
// lines x = i B, y = j B between the intersections; the landmarks stand at
// +-W/2 from the centrelines (W = street_width). The 3-D world is the
// campus of tools/campus_3d.h with
//   - level ground z = 0 (slopes 0),
//   - one building per block between streets, its facades kBuildingSetback
//     (1 m) behind the landmark line, i.e. a 3-D street width W + 2 m,
//     height U(min_height, max_height) (drawn from the 2-D seed),
//   - the point landmarks as poles: a trunk (radius 0.25 m, 3 m high) and a
//     crown (sphere of radius kCrownRadius, 4.5 m up) at each TRUE landmark.
// Scans. For every TRUE pose (x, y, theta) the sensor sits at
// (x, y, sensor_height) with yaw theta (body x ahead, z up); `beams` rays at
// angles 2 pi (b + 1/2) / beams in the body y-z plane (perpendicular to the
// motion: a push-broom), a return at the first surface within max_range,
// range noise N(0, range_sigma^2) from std::mt19937_64(seed) through our own
// transform. Points are in the sensor frame; sensor_pose is the true pose
// (the map stage replaces it by the optimized one).
//
// THREAD SAFETY: pure functions. ALLOCATION: the world; scans are streamed.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "core/scan.h"
#include "core/se2.h"
#include "core/se3.h"
#include "core/status.h"
#include "tools/campus_3d.h"
#include "tools/campus_simulator.h"
#include "tools/job/job_spec.h"

namespace graphslam::tools::job {

inline constexpr double kBuildingSetback = 1.0;  // m behind the landmark line
inline constexpr double kCrownRadius = 1.0;      // m

// The 3-D world of a simulated campus (see above).
map::Campus3d MakeCampusWorld3d(const CampusSimulatorOptions& options,
                                const SimulatedCampus& campus, double sensor_height);

// A 2-D pose lifted to the sensor's SE(3) pose: (x, y, height), yaw theta.
core::Pose3 LiftPose(const core::Pose2& pose, double height);

// The scan of every pose of `true_poses`, in order: scan k belongs to pose
// first_pose + k and run run_of_pose[k] + first_run. Stops at the first error
// of `sink`.
[[nodiscard]] Status SimulateCampusScans(const map::Campus3d& world,
                                         const std::vector<core::Pose2>& true_poses,
                                         const std::vector<int32_t>& run_of_pose,
                                         int64_t first_pose, int32_t first_run,
                                         const SimulatedScanSpec& spec, double sensor_height,
                                         uint64_t seed,
                                         const std::function<Status(map::Scan&&)>& sink);

}  // namespace graphslam::tools::job
