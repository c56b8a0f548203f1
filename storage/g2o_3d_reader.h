// Reads a 3-D g2o graph (g2o's slam3d types; Kuemmerle et al., ICRA 2011)
// into a core::Problem3d.
//
//   VERTEX_SE3:QUAT   id x y z qx qy qz qw              -> pose (initialized)
//   VERTEX_TRACKXYZ   id x y z                          -> point feature
//   EDGE_SE3:QUAT     i j x y z qx qy qz qw  Omega(21)  -> relative pose
//   EDGE_SE3_TRACKXYZ i l param x y z  Omega(6)          -> point in the frame of i
//   EDGE_SE3_XYZPRIOR i x y z  Omega(6)                  -> GPS position of i
//   PARAMS_SE3OFFSET  id x y z qx qy qz qw               -> sensor offset (identity only)
//   FIX id [id ...]
// Omega(k): the upper triangle of the information matrix, row first. The
// quaternion is normalized on reading (files carry ~7 digits); a quaternion
// whose norm is not within [0.9, 1.1] is an error. EDGE_SE3_TRACKXYZ must name
// an identity PARAMS_SE3OFFSET, or a parameter id no line defines (taken as
// the identity); other offsets are NotSupported.
//
// Edges-only files (no VERTEX line) create every vertex an edge names, in
// order of first mention, uninitialized, for core::InitializeProblem3d to
// chain. Errors: Corruption "<file>:<line>: <what>; expected <what>" for
// malformed numbers, field counts, non-positive-definite information,
// duplicate ids, edges to undefined vertices or vertices of the wrong kind,
// self-loops; NotSupported for unknown (and 2-D) tags.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(records); streamed line by line.
#pragma once

#include <string>

#include "core/information_repair.h"
#include "core/problem_3d.h"
#include "core/status.h"

namespace graphslam::storage {

// With `repairs` (opt-in), an information matrix that is not positive
// definite is repaired (core/information_repair.h) and counted there instead
// of rejected.
StatusOr<core::Problem3d> ReadG2o3d(const std::string& path,
                                    core::InformationRepairs* repairs = nullptr);

}  // namespace graphslam::storage
