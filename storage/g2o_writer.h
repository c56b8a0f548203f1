// Writes a core::Problem2d as a 2-D g2o graph file (the format g2o_reader.h
// reads, and g2o_viewer / g2o itself load), through WriteFileAtomically.
//
//   VERTEX_SE2 id x y theta      every pose, in index order
//   VERTEX_XY  id x y            every feature, in index order
//   FIX id                       every fixed pose
//   EDGE_SE2 i j dx dy dth  xx xy xt yy yt tt      relative poses, and
//                                                  velocity motions (below)
//   EDGE_SE2_XY i l x y  xx xy yy                  point and range-bearing
//                                                  observations (below)
//   EDGE_PRIOR_SE2_XY i x y  xx xy yy              GPS (g2o EdgeSE2XYPrior)
// Numbers are printed "%.17g" (exact round trip). Pose and feature ids share
// g2o's one number space. When they collide (MRCLAM: poses 0..n-1, landmark
// subjects 6..20), the features are renumbered past the largest pose id, in
// their order: written id = feature id + G2oFeatureIdOffset(problem), with
//   offset = max pose id + 1 - min feature id   (0 when the ids are disjoint),
// and the file opens with the comment line
//   # graphslam: feature ids renumbered: VERTEX_XY id = feature id + <offset>
// (g2o and our reader skip '#' lines; the features CSV keeps the original
// ids, and `solve --report` gives the offset as g2o_feature_id_offset). g2o has no notion of an uninitialized vertex: such
// vertices are written with their current values.
//
// Range-bearing -> EDGE_SE2_XY. z = (r, phi) becomes the point in the robot
// frame p = r (cos phi, sin phi); the covariance is propagated through the
// Jacobian of the polar -> cartesian map (first order):
//   J = dp/d(r, phi) = [cos phi  -r sin phi]      Sigma_p = J Sigma_rb J^T
//                      [sin phi   r cos phi]  =>  Omega_p = J^-T Omega_rb J^-1
// J is singular at r = 0, so a range <= 0 is rejected (InvalidArgument).
//
// Velocity motion -> EDGE_SE2. The control u moves x_{t-1} to g(u, x_{t-1});
// the displacement in the frame of x_{t-1} does not depend on x_{t-1}:
//   z = Between(x, g(u, x)) = g(u, 0)            (PredictVelocityMotion)
// The motion information Omega_w (of e_w = x_t - g(u, x_{t-1}), world frame)
// is rotated into the frame of g2o's residual e = t2v(Z^-1 X_i^-1 X_j), which
// to first order is e = diag(R(phi)^T, 1) e_w with phi = theta_from + z_theta:
//   Omega = diag(R(phi)^T, 1) Omega_w diag(R(phi), 1)
// theta_from is the current value of pose `from` (for poses read from MRCLAM,
// the dead-reckoned pose at which Omega_w was computed).
//
// THREAD SAFETY: reentrant. ALLOCATION: one line buffer.
#pragma once

#include <string>

#include "core/problem.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

// The offset above; InvalidArgument if the renumbered ids would overflow.
StatusOr<int64_t> G2oFeatureIdOffset(const core::Problem2d& problem);

// `env` defaults to Env::Default(); an existing `path` survives any failure.
[[nodiscard]] Status WriteG2o(const core::Problem2d& problem, const std::string& path,
                              Env* env = nullptr);

}  // namespace graphslam::storage
