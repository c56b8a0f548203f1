// A 3-D campus seen by a vertically scanning laser, with ground truth: the
// scan data of issue 5 (Thrun & Montemerlo map a campus with a robot whose
// laser scans a vertical plane, building the 3-D map as the robot drives).
//
// World (metres, z up).
//   Ground: the plane z = slope_x x + slope_y y (sloped, not level).
//   Streets: the grid lines x = i B (0 <= i <= columns) and y = j B
//   (0 <= j <= rows), B = block_size, street_width W wide.
//   Buildings: one box per block, footprint [i B + W/2, (i+1) B - W/2] x
//   [j B + W/2, (j+1) B - W/2], from below the ground up to a height drawn
//   in [min_height, max_height] above the ground at the block's centre.
//   Trees: along both sides of every street, tree_spacing apart, at
//   W/2 - tree_setback from the centreline, away from intersections: a trunk
//   (vertical cylinder, radius 0.25 m, 3 m) and a crown (sphere, radius
//   crown_radius, centred 4.5 m above the ground).
// Robot. Drives every row street (run 0, a boustrophedon over y = j B), then
// every column street (run 1, over x = i B), on the centreline, a pose every
// pose_spacing metres. Its body frame: x along the street tangent to the
// ground, z the ground normal; the laser sits sensor_height above the ground
// on the z axis. The laser scans the body y-z plane (perpendicular to the
// motion; a push-broom): `beams` rays over 360 degrees, a return at the first
// surface within max_range (no return otherwise: the sky), range noise
// N(0, range_sigma^2). The scan's points are in the sensor frame, its
// sensor_pose the TRUE pose (ground truth).
//
// Determinism: std::mt19937_64 with `seed`, through our own uniform/normal
// transforms.
// THREAD SAFETY: pure functions. ALLOCATION: the world; the scans are
// streamed to a callback one at a time.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <vector>

#include "core/se3.h"
#include "core/status.h"
#include "core/scan.h"

namespace graphslam::map {

struct Campus3dOptions {
  int columns = 15;  // blocks along x (15 x 40 m = 600 m)
  int rows = 20;     // blocks along y (20 x 40 m = 800 m)
  double block_size = 40.0;
  double street_width = 12.06;  // faces off the 0.1 m cell boundaries
  double min_height = 8.0, max_height = 20.0;
  double slope_x = 0.02, slope_y = -0.01;
  double tree_spacing = 9.0, tree_setback = 1.5, crown_radius = 1.8;
  double pose_spacing = 2.0;
  double sensor_height = 1.5;
  int beams = 360;
  double max_range = 40.0;
  double range_sigma = 0.0;
  uint64_t seed = 1;

  [[nodiscard]] Status Validate() const;
};

struct Box {
  Eigen::Vector3d lo, hi;
};
struct Tree {
  Eigen::Vector2d xy;
};

struct Campus3d {
  Campus3dOptions options;
  std::vector<Box> buildings;
  std::vector<Tree> trees;

  double GroundZ(double x, double y) const { return options.slope_x * x + options.slope_y * y; }
  // Distance along the unit direction d from o to the first surface, or
  // +infinity if none within max_range.
  // `nearby_trees` (optional) restricts the trees tested (NearbyTrees).
  double Cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double max_range,
              const std::vector<int>* nearby_trees = nullptr) const;
  // Indexes of the trees within `range` (horizontally, plus the crown) of o.
  std::vector<int> NearbyTrees(const Eigen::Vector3d& o, double range) const;
};

// The world of `options` (deterministic in the seed).
Campus3d MakeCampus3d(const Campus3dOptions& options);

// The true sensor poses of the drive (runs in pose order) and their runs.
void Campus3dTrajectory(const Campus3d& campus, std::vector<core::Pose3>* poses,
                        std::vector<int32_t>* runs);

// Simulates the scan of every pose, in order, handing each to `sink`; stops at
// the first error `sink` returns.
[[nodiscard]] Status SimulateCampus3dScans(const Campus3d& campus,
                                           const std::function<Status(Scan&&)>& sink);

}  // namespace graphslam::map
