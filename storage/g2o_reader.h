// Reads a 2-D g2o graph file (Kuemmerle et al., "g2o: A General Framework for
// Graph Optimization", ICRA 2011; the text format of g2o's OptimizableGraph::
// load) into a core::Problem2d.
//
//   VERTEX_SE2  id x y theta                  -> pose (initialized)
//   VERTEX_XY   id x y                        -> feature (initialized)
//   EDGE_SE2    i j dx dy dth  xx xy xt yy yt tt
//       -> RelativePoseConstraint, z = pose j in the frame of pose i,
//          Omega = the symmetric matrix of the upper triangle (g2o convention)
//   EDGE_SE2_XY i l x y  xx xy yy             -> Observation kPointXY
//   EDGE_PRIOR_SE2_XY i x y  xx xy yy         -> GpsConstraint (g2o EdgeSE2XYPrior)
//   FIX id [id ...]                           -> pose_fixed = 1
//   # comment, blank lines
// Pose and landmark ids share one number space. Vertices may follow the edges
// that use them. Dense indices follow the order of the VERTEX lines.
//
// Edges-only files (no VERTEX line at all, e.g. SE-Sync's CSAIL.g2o): every id
// an edge names becomes a vertex, in order of first mention, uninitialized
// (pose_initialized = 0, feature_initialized = 0), so the initializer chains
// odometry. If the file has any VERTEX line, an edge to an id no VERTEX line
// defines is an error:
//   "CSAIL.g2o:12: EDGE_SE2 refers to vertex 77, which no VERTEX line defines; ..."
//
// Rejected (Corruption, "<file>:<line>: <what>; expected <what>"): malformed or
// non-finite numbers, wrong field counts, information not positive definite,
// duplicate vertex ids, edges to undefined vertices or to a vertex of the wrong
// kind, self-loops. NotSupported: unknown tags, 3-D tags (VERTEX_SE3:QUAT, ...).
// NotFound: missing file.
//
//   DATA_FEATURE_POINTXY a b x y xx xy yy     -> Observation kPointXY without
//       landmark id, from the VERTEX_SE2 defined last (victoriaPark-noassoc);
//       each gets a feature of its own (id core::kNoFeatureId, core/unidentified_features.h) for data association.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(file records); the file is streamed
// line by line.
#pragma once

#include <string>

#include "core/information_repair.h"
#include "core/problem.h"
#include "core/status.h"

namespace graphslam::storage {

// Sets problem.source = path and the `line` field of every element. With
// `repairs` (opt-in), an information matrix that is not positive definite is
// repaired (core/information_repair.h) and counted there instead of rejected.
StatusOr<core::Problem2d> ReadG2o(const std::string& path,
                                  core::InformationRepairs* repairs = nullptr);

}  // namespace graphslam::storage
