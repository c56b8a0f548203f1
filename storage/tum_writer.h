// Writes the poses of a core::Problem2d as a TUM RGB-D trajectory (Sturm et
// al., "A Benchmark for the Evaluation of RGB-D SLAM Systems", IROS 2012), the
// input of evo / the TUM evaluation scripts, through WriteFileAtomically:
//
//   # timestamp x y z qx qy qz qw
//   t x y 0 0 0 sin(theta/2) cos(theta/2)        one line per pose, index order
//
// The planar pose is the rotation theta about z: q = (0, 0, sin(th/2),
// cos(th/2)). t = pose_stamps[i], or the pose index i when the stamp is NaN
// (inputs without time). Numbers are "%.17g".
//
// THREAD SAFETY: reentrant. ALLOCATION: one line buffer.
#pragma once

#include <string>

#include "core/problem.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage {

[[nodiscard]] Status WriteTum(const core::Problem2d& problem, const std::string& path,
                              Env* env = nullptr);

}  // namespace graphslam::storage
