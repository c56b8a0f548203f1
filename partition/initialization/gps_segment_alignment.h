// AlignOdometryToGps: a dead-reckoned trajectory put onto its GPS fixes,
// segment by segment, before the pose-graph solve of `graphslam solve
// --initialization pose-graph` (partition/initialization/pose_graph_initialization.h).
//
// Why. Dead reckoning over a long trajectory drifts in heading; at 200 000
// poses (the sim1e6 benchmark, GPS every 25 poses) the chained guess is
// kilometres off, and Levenberg-Marquardt on the pose-only problem creeps
// (rho ~0.5, chi2 -0.4 % per iteration, 1.77e10 -> 1.65e10 in 20
// iterations): the heading errors make the linearization useless beyond a few
// metres. Between two GPS fixes, though, the odometry is accurate; only the
// segment's start and heading are wrong. Fixing those is linear in the poses.
//
// Method. An odometry chain is a maximal index range [s, e] with a relative
// pose or a motion constraint between every i and i + 1 (either direction).
// Let g_0 < ... < g_m be its poses with a GPS fix (the first fix of each), x
// the current (dead-reckoned) poses. For each pair a = g_k, b = g_{k+1}, in
// the frame of x_a the chained displacement is d = R(-th_a)(t_b - t_a); the
// fixes give D = z_b - z_a. The segment's correction is the rigid motion
//   C_k = (z_a, atan2(D) - atan2(d)) (+) x_a^{-1},
// i.e. x_a moves onto its fix with the heading that turns d along D, and
//   x_i <- C_k (+) x_i      for a <= i < b,
// which keeps every odometry edge inside the segment exact. Poses before g_0
// take C_0, poses from g_m on take C_{m-1}. A pair with |d| or |D| below
// `min_displacement` (a stop: the direction is noise) takes the previous
// pair's correction (the next one's for leading pairs); a chain where every
// pair is such is left alone, as is a chain with fewer than two fixes or with
// a fixed pose (the gauge is the caller's). Features are not touched (the
// pose-graph initializer re-places them).
//
// Cost: O(poses + constraints) time and memory.
// THREAD SAFETY: mutates *problem only.
#pragma once

#include <cstdint>

#include "core/problem.h"

namespace graphslam::partition {

struct GpsAlignmentSummary {
  int64_t chains = 0;           // odometry chains aligned
  int64_t segments = 0;         // GPS pairs whose own correction was used
  int64_t poses_moved = 0;
};

// Units of `min_displacement` are the problem's (metres for every importer).
GpsAlignmentSummary AlignOdometryToGps(core::Problem2d* problem, double min_displacement = 1.0);

}  // namespace graphslam::partition
