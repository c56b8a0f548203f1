// Writes a core::Problem3d as a 3-D g2o graph (the records ReadG2o3d reads),
// atomically (storage/atomic_file.h):
//
//   PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1          (only if there are observations)
//   VERTEX_SE3:QUAT id x y z qx qy qz qw      every pose, index order
//   VERTEX_TRACKXYZ id x y z                  every feature
//   FIX id                                    every fixed pose
//   EDGE_SE3:QUAT i j x y z qx qy qz qw Omega(21)
//   EDGE_SE3_TRACKXYZ i l 0 x y z Omega(6)
//   EDGE_SE3_XYZPRIOR i x y z Omega(6)
// Numbers are "%.17g" (they read back bit-identical); quaternions are written
// with qw >= 0.
//
// THREAD SAFETY: reentrant. ALLOCATION: one line buffer.
#pragma once

#include <string>

#include "core/problem_3d.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

[[nodiscard]] Status WriteG2o3d(const core::Problem3d& problem, const std::string& path,
                                Env* env = nullptr);

// The poses as a TUM trajectory: "# timestamp x y z qx qy qz qw", one line per
// pose in index order, timestamp = the pose id (3-D inputs carry no time).
[[nodiscard]] Status WriteTum3d(const core::Problem3d& problem, const std::string& path,
                                Env* env = nullptr);

}  // namespace graphslam::storage
