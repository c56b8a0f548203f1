// A 2-D campus simulator with ground truth: the synthetic data set of the kind
// Thrun & Montemerlo use to study GraphSLAM at scale (a vehicle driving the
// streets of a city block grid, seeing trees and poles), with measurements
// whose noise is exactly what our models assume, so that the chi2 of the TRUE
// state per residual dimension is ~1 and solver accuracy can be measured
// against the truth (tools/trajectory_metrics.h).
//
// World. Intersections at (i B, j B), i < columns, j < rows, B = block_size;
// streets are the grid lines between them, square buildings fill the rest.
// Point landmarks stand on both sides of every street segment, offset
// street_width / 2 from the centerline, at random spacing
// U(min_landmark_spacing, max_landmark_spacing), away from the intersections.
// With `features` > 0 the grid is the smallest near-square one holding at
// least that many landmarks and a random subset is dropped to leave exactly
// `features`; with 0 the grid is sized from the driving distance
// D = poses * speed * dt so that the street length is about D / 4, i.e. the
// robot drives every street several times (loop closures).
//
// Robot. Each run starts at a random intersection, heading along a random
// street, and drives the centerlines: at each intersection it goes straight
// (weight straight_probability) or turns left / right (the rest, split
// evenly) onto a street that exists (no U-turns; the grid edge is never
// crossed). Turns are quarter circles of radius turn_radius. A pure-pursuit
// controller (Coulter 1992) on the TRUE pose picks the commanded control
// u = (speed, omega). That commanded control is what the log records; the
// executed motion is the velocity model with the control perturbed as in
// Probabilistic Robotics Table 5.3 (sample_motion_model_velocity):
//
//   (v', w', gamma) = (v, w, 0) + N(0, M),
//   M = diag(a1 v^2 + a2 w^2, a3 v^2 + a4 w^2, a5 v^2 + a6 w^2)
//   x_t = g((v', w'), x_{t-1}) + (0, 0, gamma dt) + N(0, diag(s_xy^2, s_xy^2, s_th^2))
//
// so that e = x_t - g(u, x_{t-1}) ~ N(0, V M V^T + floor) to first order,
// which is VelocityMotionCovariance(x_{t-1}, u, noise) (velocity_motion_model.h)
// with the floor terms min_sigma_xy, min_sigma_theta. The constraint
// information is the inverse of that covariance at the true x_{t-1} and the
// recorded control.
//
// Sensing. Range-bearing (range_bearing_model.h) to every landmark within
// sensor_range and |bearing| <= field_of_view / 2 of the true pose, with
// N(0, range_sigma^2), N(0, bearing_sigma^2) noise (bearing wrapped) and
// information diag(1 / range_sigma^2, 1 / bearing_sigma^2). No occlusion by
// buildings. GPS (gps_model.h): every gps_every-th pose of a run (k = 0,
// K, 2K, ...), z = true (x, y) + N(0, gps_sigma^2 I), information I / gps_sigma^2.
//
// Problem layout. Pose ids 0..poses-1 (runs one after another), pose stamps
// k * dt with k the index within its run; feature ids feature_id_base + index,
// features in the order of true_features. Initial guesses: the first pose of
// run 0 is the truth, fixed when there is no GPS (it anchors the gauge); the
// first pose of a later run is the truth plus N(0, initial_position_sigma^2)
// in x, y and N(0, initial_heading_sigma^2) in theta. Every other pose and
// every feature is uninitialized (pose_initialized / feature_initialized 0)
// but holds a hint: the dead-reckoned pose (the run's first guess chained
// through the recorded controls) and the first-sight inversion of the
// feature's first observation from it (unobserved features: the origin).
//
// Determinism: everything is drawn from one std::mt19937_64 seeded with
// `seed`, through our own uniform/normal transforms (not the std::
// distributions, whose output differs between standard libraries), so a seed
// gives the same campus wherever the math library rounds log/sin/cos alike.
//
// THREAD SAFETY: SimulateCampus is reentrant (no global state).
// ALLOCATION: O(poses + features + observations); landmarks are found through
// a uniform grid of sensor_range cells, so each pose costs O(nearby landmarks).
#pragma once

#include <cstdint>
#include <numbers>
#include <vector>

#include "core/problem.h"
#include "core/se2.h"
#include "core/status.h"
#include "core/velocity_motion_model.h"

namespace graphslam::tools {

// Control noise of the simulator: speed 10 % off per step (sigma_v = 0.1 v),
// heading drifting 0.0077 rad per step on straights (a random walk of ~1.4 deg
// per 10 m at the default speed and dt). With these a dead-reckoned start lets
// Levenberg-Marquardt reach the global minimum on a 2000-pose campus; 3x the
// heading noise (a3 = a5 = 1e-4) already left it in a local one (seed 3).
// Looser values (e.g. core::VelocityNoise's defaults) also make the
// first-order noise model less exact: the cross term n_v n_w of g inflates the
// cross-track variance by about a1, i.e. chi2/dof of the truth by ~a1/3
// (0.3 % here, 3-5 % at a1 = 0.1).
inline core::VelocityNoise DefaultCampusNoise() {
  core::VelocityNoise noise;
  const double alpha[6] = {0.01, 0.001, 0.00003, 0.01, 0.00003, 0.01};
  for (int i = 0; i < 6; ++i) noise.alpha[i] = alpha[i];
  noise.min_sigma_xy = 1e-3;
  noise.min_sigma_theta = 1e-3;
  return noise;
}

struct CampusSimulatorOptions {
  int64_t poses = 2000;  // in total, split evenly over the runs
  int64_t features = 0;  // landmarks; 0: derived from the campus size (see above)
  int runs = 1;
  int gps_every = 0;  // 0: no GPS
  uint32_t seed = 1;

  double block_size = 40;    // m, pitch of the street centerlines (building + street)
  double street_width = 12;  // m; landmarks stand at +-street_width / 2
  double min_landmark_spacing = 6;   // m, along one side of a street
  double max_landmark_spacing = 10;  // m
  double turn_radius = 0;            // m; 0: street_width / 2
  double straight_probability = 0.5;  // at an intersection where straight on is possible
  double lookahead = 3;              // m, pure-pursuit lookahead
  double max_omega = 1.5;            // rad/s, controller limit

  double speed = 2.0;  // m/s
  double dt = 0.5;     // s between poses

  double sensor_range = 15;                   // m
  double field_of_view = std::numbers::pi;  // rad, centered ahead (180 deg)
  double range_sigma = 0.1;                   // m
  double bearing_sigma = 0.02;                // rad
  double gps_sigma = 1.0;                     // m

  double initial_position_sigma = 2.0;  // m, first guess of runs after the first
  double initial_heading_sigma = 0.1;   // rad

  int64_t feature_id_base = 1000000;  // must be >= poses so ids never collide (g2o)
  core::VelocityNoise noise = DefaultCampusNoise();

  // InvalidArgument naming the field, its value and the allowed range.
  [[nodiscard]] Status Validate() const;
};

struct SimulatedCampus {
  core::Problem2d problem;  // noisy measurements and initial guesses (see above)
  std::vector<core::Pose2> true_poses;      // one per problem pose
  std::vector<core::Point2> true_features;  // one per problem feature
  std::vector<int32_t> run_of_pose;         // 0-based run of each pose

  int grid_columns = 0;  // intersections along x
  int grid_rows = 0;     // intersections along y
  double distance_travelled = 0;  // m, true path length over all runs
  int64_t observed_features = 0;  // features with at least one observation
};

// Validates `options` (InvalidArgument) and simulates.
StatusOr<SimulatedCampus> SimulateCampus(const CampusSimulatorOptions& options);

}  // namespace graphslam::tools
