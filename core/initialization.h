// Initial guess and sanity checks of a Problem2d before the first
// linearization (paper Table 1, GraphSLAM_initialize), generalized to
// relative-pose edges, GPS anchors and features.
//
// Poses. Table 1 sets mu_0 = 0 and chains the deterministic motion model,
//   mu_t = g(u_t, mu_{t-1}).
// Here the chaining is a breadth-first search over the pose graph, started
// from every pose whose guess came from the input (pose_initialized == 1), or
// from pose 0 set to (0, 0, 0) when none did. It follows
//   relative poses:  x_to = x_from (+) z,   x_from = x_to (+) z^{-1}
//   motions:         x_to = g(u, x_from),   x_from = g^{-1}(u, x_to)
// and never overwrites a pose the input initialized. A pose that no chain
// reaches (connected only through shared features) starts at its GPS fix with
// theta = 0, else at the nearest lower-index initialized pose, else at 0; the
// same rule seeds pose 0 when no pose has a guess (its GPS fix, else 0).
//
// Features. A feature without a guess (feature_initialized == 0) is placed by
// its first observation (lowest index in problem->observations), inverting the
// measurement model: m = t + r (cos(th + phi), sin(th + phi)) for range-bearing,
// m = t + R(th) z for point observations. Unobserved features are left alone.
//
// Checks, all done before anything is modified:
//   - every index of every constraint is in range;
//   - every information matrix is finite, symmetric and positive definite
//     (Cholesky succeeds);
//   - every pose is connected to an anchor (a fixed pose; pose 0 when none is
//     fixed; any pose with a GPS fix) through relative poses, motions, robot
//     sightings (pose_range_bearings) or a shared feature (union-find). Otherwise the Hessian is singular; the
//     message names the source file, the pose's line and its id.
// Failures are Status::InvalidArgument, e.g.
//   "intel.g2o:57: pose 56 is not connected to the anchor (pose 0) by any
//    constraint; expected an odometry edge or a shared landmark"
//
// THREAD SAFETY: mutates *problem only; distinct problems may be initialized
// concurrently. ALLOCATION: O(poses + features + constraints).
#pragma once

#include "core/problem.h"
#include "core/status.h"

namespace graphslam::core {

// Runs the checks above, then fills in every missing pose and feature guess
// and marks them initialized. On error *problem is unchanged.
Status InitializeProblem(Problem2d* problem);

// The checks of InitializeProblem for one observation (indices in range,
// information positive definite), with its messages. For callers that stream
// observations past the problem instead of holding them
// (partition/initialization/first_sight_initialization.h).
Status CheckObservation(const Problem2d& problem, const Observation& observation);

// Table 1's feature placement for one observation: when its feature has no
// guess yet, places it by inverting the measurement model from the pose's
// current guess and marks it initialized; else does nothing. Feeding the
// observations in input order after the poses are initialized gives
// InitializeProblem's feature guesses (the first observation places).
void PlaceFeature(Problem2d* problem, const Observation& observation);

// The checks of InitializeProblem alone (indices, information matrices,
// connectivity), without modifying the problem.
Status ValidateProblem(const Problem2d& problem);

}  // namespace graphslam::core
