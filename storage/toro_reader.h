// Reads the TORO / GTSAM ".graph" text format (Grisetti et al., TORO; the
// files GTSAM's load2D / load3D read, e.g. its examples/Data/w100.graph) into
// a core::Problem2d or core::Problem3d. docs/formats/toro_graph.md has the
// full reading; in short:
//
// 2-D
//   VERTEX2 id x y theta                       -> pose guess
//   EDGE2 i j dx dy dth  I11 I12 I22 I33 I13 I23
//       -> RelativePoseConstraint, z = pose j in the frame of pose i, with the
//          INFORMATION matrix in TORO's order (x, y, theta):
//              Omega = [I11 I12 I13; I12 I22 I23; I13 I23 I33]
//          (not g2o's row-first upper triangle xx xy xt yy yt tt).
//   BR i l bearing range sigma_bearing sigma_range
//       -> Observation kRangeBearing of landmark l from pose i, z = (range,
//          bearing), Omega = diag(1/sigma_range^2, 1/sigma_bearing^2)
//          (GTSAM's BearingRangeFactor with Sigmas(sigma_b, sigma_r)).
//          Landmark ids are their own number space (GTSAM's L(l) keys).
//   EQUIV i j  -> read and checked (two pose ids), adds no constraint: it
//          states that poses i and j are the same place, which the files also
//          say by an EDGE2 i j (w100.graph has one for each of its 40 EQUIV
//          lines); GTSAM's load2D skips the line too.
// 3-D
//   VERTEX3 id x y z roll pitch yaw            -> pose guess, R = Rz(yaw) Ry(pitch) Rx(roll)
//   EDGE3 i j x y z roll pitch yaw I(21)
//       -> relative pose, I the upper triangle (row first) of the information
//          over (x, y, z, roll, pitch, yaw). Our error [t; vec(q)] has
//          vec(q) = angles / 2 to first order, so the rotation rows and
//          columns are scaled by 2 each (as storage/isam_3d_reader.h does).
//
// A file is 2-D or 3-D; the first VERTEX/EDGE record decides
// (storage/dimension_detection.h). Poses are created in order of first
// mention; a pose no VERTEX line gives a guess to is uninitialized (the
// initializer chains odometry to it). The first pose is the gauge anchor.
// Rejected (Corruption, "<file>:<line>: ...; expected ..."): malformed or
// non-finite numbers, wrong field counts, information not positive definite,
// sigmas <= 0, self-loops, a pose defined twice. NotSupported: records of
// the other dimension and unknown tags.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(records); streamed line by line.
#pragma once

#include <string>

#include "core/information_repair.h"
#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/status.h"

namespace graphslam::storage {

// With `repairs` (opt-in), an EDGE2 / EDGE3 information matrix that is not
// positive definite is repaired (core/information_repair.h) and counted
// instead of rejected.
StatusOr<core::Problem2d> ReadToro(const std::string& path,
                                   core::InformationRepairs* repairs = nullptr);
StatusOr<core::Problem3d> ReadToro3d(const std::string& path,
                                     core::InformationRepairs* repairs = nullptr);

}  // namespace graphslam::storage
