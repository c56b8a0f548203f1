// Ground truth of a 2-D run from a trajectory file: TUM or KITTI odometry
// (storage/trajectory_format.h), projected onto the plane.
//
// Both formats are 3-D. A pose becomes (x, y, yaw) (storage/stamped_pose.h,
// ProjectToPlane): z, roll and pitch are dropped. KITTI poses are camera
// poses (x right, y down, z forward) and are first turned into the vehicle
// convention (x forward, y left, z up; storage/kitti_pose_reader.h,
// KittiCameraToBody), so their x, y is the ground plane.
//
// Time: TUM stamps as written. KITTI without a times file: the stamp of
// frame i is i, so an estimate is matched to it by pose index (inputs
// without time, g2o and iSAM, stamp their poses by index too); with a times
// file, times[i].
//
// THREAD SAFETY: reentrant. ALLOCATION: O(poses).
#pragma once

#include <string>
#include <vector>

#include "core/status.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools {

struct GroundTruthFile {
  std::string path;
  std::string format = "auto";  // auto, tum, kitti
  std::string times;            // KITTI: optional times.txt
};

// Errors of the readers ("<file>:<line>: ..."), InvalidArgument for a bad
// format name or a times file given with TUM.
StatusOr<std::vector<StampedPose2>> ReadGroundTruth(const GroundTruthFile& file);

}  // namespace graphslam::tools
