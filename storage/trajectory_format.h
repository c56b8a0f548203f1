// Which trajectory format a ground-truth file is in, and reading it.
//
//   tum    "t x y z qx qy qz qw" per line (storage/tum_reader.h)
//   kitti  "r11 r12 r13 tx ... r33 tz" per line (storage/kitti_pose_reader.h)
//
// Detection reads the first record (the first line that is neither blank nor
// a '#' comment): 8 fields is TUM, 12 is KITTI; anything else is Corruption
// "<file>:<line>: trajectory line has N fields; expected 8 (TUM) or 12
// (KITTI)".
//
// THREAD SAFETY: reentrant. ALLOCATION: one line (detection).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"
#include "storage/stamped_pose.h"

namespace graphslam::storage {

enum class TrajectoryFormat { kTum, kKitti };

// "tum" or "kitti"; InvalidArgument naming the choices ("auto" among them:
// the callers resolve it with DetectTrajectoryFormat).
StatusOr<TrajectoryFormat> ParseTrajectoryFormat(std::string_view name);
StatusOr<TrajectoryFormat> DetectTrajectoryFormat(const std::string& path);

// Reads `path` in `format`; `kitti_times` (KITTI only; InvalidArgument with
// TUM, which carries its times) is the optional times file.
StatusOr<std::vector<StampedPose3>> ReadTrajectory(const std::string& path,
                                                   TrajectoryFormat format,
                                                   const std::string& kitti_times = "");

}  // namespace graphslam::storage
