// Reads a TUM RGB-D trajectory (Sturm et al., "A Benchmark for the Evaluation
// of RGB-D SLAM Systems", IROS 2012; the format evo and the TUM scripts read):
//
//   # comment
//   t x y z qx qy qz qw          one pose per line: time [s], position [m],
//                                orientation as a quaternion (Hamilton, w last)
//
// Fields are separated by blanks; '#' lines and blank lines are skipped; a
// file may be zstd-compressed (storage/compressed_file.h). The quaternion is
// normalized; times are bounded as internal/text_reader.h says. Errors are Corruption "<file>:<line>: <what>; expected <what>":
// a line without 8 fields, a field that is not a finite number, a quaternion
// of norm below 1e-9. Poses are kept in file order: a file may hold several
// runs one after another, each starting its times anew (the simulator's
// ground_truth.tum). NotFound / IOError when the file cannot be read.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(poses); the file is streamed.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"
#include "storage/stamped_pose.h"

namespace graphslam::storage {

StatusOr<std::vector<StampedPose3>> ReadTumTrajectory(const std::string& path);

}  // namespace graphslam::storage
