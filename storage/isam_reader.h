// Reads a 2-D iSAM text file (Kaess, Ranganathan, Dellaert, "iSAM: Incremental
// Smoothing and Mapping", T-RO 2008; the data/ files of the iSAM library) into
// a core::Problem2d.
//
//   ODOMETRY i j dx dy dth  sxx sxy sxt syy syt stt   (EDGE2 is a synonym)
//       -> RelativePoseConstraint, z = pose j in the frame of pose i
//   LANDMARK i l dx dy  sxx sxy syy
//       -> Observation kPointXY: (dx, dy) is landmark l in the frame of pose i
//          (the cartesian point, not range-bearing: the same numbers appear in
//          victoriaPark-full.g2o as EDGE_SE2_XY)
// The trailing numbers are the upper-triangular square root R of the
// information matrix, row-first (README.isam-data.txt), so
//   Omega = R^T R.
// (Victoria Park's odometry R = diag(100, 500, 500) is thus Omega =
// diag(1e4, 2.5e5, 2.5e5), not the g2o file's diag(100, 500, 500); see the
// datasets INDEX caveat.)
//
// iSAM files have no initial guesses: poses are created in order of first
// mention, uninitialized; landmarks likewise. Pose ids and landmark ids are
// separate number spaces, as in iSAM's loader (separate pose and point maps).
// In victoriaPark.txt they happen to be disjoint: 6969 pose ids and 151
// landmark ids (5..6884) drawn from one 0..7119 sequence, the numbering of the
// g2o version of the same data.
//
// Rejected (Corruption, "<file>:<line>: ...; expected ..."): malformed or
// non-finite numbers, wrong field counts, singular square-root information,
// self-loops. NotSupported: 3-D tags (EDGE3, POINT3, ...) and unknown tags.
// With `repairs` (opt-in), a singular R is not rejected: Omega = R^T R is
// repaired (core/information_repair.h) and counted there.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(records); streamed line by line.
#pragma once

#include <string>

#include "core/information_repair.h"
#include "core/problem.h"
#include "core/status.h"

namespace graphslam::storage {

StatusOr<core::Problem2d> ReadIsam(const std::string& path,
                                   core::InformationRepairs* repairs = nullptr);

}  // namespace graphslam::storage
