// Placing poses by chaining odometry (relative poses and velocity motions)
// from poses already placed: the initial guess of each new stage of
// progressive initialization and of the incremental association.
//
//   x_p = x_q (+) z        (relative pose q->p)      x_p = x_q (+) z^{-1}  (p->q)
//   x_p = g(u, x_q)        (motion q->p, Table 1)    x_p = g^{-1}(u, x_q)  (p->q)
// with q the placed neighbour of highest index (the odometry predecessor). The
// lowest pose no such edge reaches (the start of another odometry chain, e.g.
// the first pose of a later run) keeps its input guess and the poses after it
// chain from it: an offset from an earlier pose's guess would carry that
// pose's dead-reckoning drift over to an unrelated chain.
//
// THREAD SAFETY: pure functions. ALLOCATION: O(poses + odometry edges).
#pragma once

#include <cstdint>
#include <vector>

#include "core/problem.h"

namespace graphslam::partition::internal {

// An odometry-like edge seen from one of its poses.
struct PoseEdge {
  int32_t other = -1;       // the pose at the other end
  int32_t constraint = -1;  // index into relative_poses or motions
  bool motion = false;      // motions (else relative_poses)
  bool incoming = false;    // this pose is the edge's `to`
};

// Per pose, its relative-pose and motion edges (self-loops left out).
// Indices must be valid (checked by the callers).
std::vector<std::vector<PoseEdge>> OdometryAdjacency(const core::Problem2d& problem);

// Places the poses [begin, end) not yet placed (*placed[p] == 0) by chaining
// odometry from placed poses below `end`, as above; marks them placed.
void PlacePoses(const core::Problem2d& problem, const std::vector<std::vector<PoseEdge>>& adjacency,
                int32_t begin, int32_t end, std::vector<core::Pose2>* poses,
                std::vector<uint8_t>* placed);

}  // namespace graphslam::partition::internal
