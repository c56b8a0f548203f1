// Whether a g2o or iSAM input holds a 3-D problem: the first record whose tag
// decides it (g2o: VERTEX_SE3:QUAT, VERTEX_TRACKXYZ, EDGE_SE3*, PARAMS_SE3OFFSET
// -> 3-D; VERTEX_SE2, VERTEX_XY, EDGE_SE2*, EDGE_PRIOR_SE2_XY -> 2-D; iSAM:
// EDGE3, POINT3 -> 3-D; EDGE2, ODOMETRY, LANDMARK -> 2-D; TORO .graph:
// VERTEX3, EDGE3 -> 3-D; VERTEX2, EDGE2, BR, EQUIV -> 2-D). FIX and comments
// decide nothing. A file with no deciding record is 2-D (its reader then
// reports what is wrong). Other formats (MRCLAM, native) are 2-D.
//
// THREAD SAFETY: reentrant. ALLOCATION: one line.
#pragma once

#include <string>

#include "core/status.h"
#include "storage/format_detection.h"

namespace graphslam::storage {

StatusOr<bool> IsThreeDimensional(const std::string& path, InputFormat format);

}  // namespace graphslam::storage
