// Reads a KITTI odometry poses file (Geiger et al., "Are we ready for
// Autonomous Driving? The KITTI Vision Benchmark Suite", CVPR 2012;
// dataset/poses/NN.txt) and, optionally, its times file (sequences/NN/
// times.txt).
//
//   r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz     one line per frame
//
// Line i is the 3x4 matrix [R | t] of frame i: the pose of the left camera
// at frame i in the frame of the left camera at frame 0. The file has no
// time: a pose's stamp is the frame index i (seconds in name only, so that
// matching by time is matching by index), or, given a times file (one time
// [s] per line, as many lines as poses), times[i].
//
// The camera frame is x right, y down, z forward. KittiCameraToBody turns a
// pose into the vehicle convention x forward, y left, z up (the frame the
// 2-D solver's x, y, theta live in):
//   C = [0 0 1; -1 0 0; 0 -1 0],  p' = C p,  R' = C R C^T.
//
// Errors are Corruption "<file>:<line>: <what>; expected <what>": a line
// without 12 fields, a field that is not a finite number, a rotation block
// that is not a rotation (max |R^T R - I| > 1e-3 or det R <= 0; the published
// files print 6-9 digits), a times line without one number, times that
// decrease, or a times file with a different number of lines than poses (named
// with both counts). NotFound / IOError when a file cannot be read.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(poses); the files are streamed.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"
#include "storage/stamped_pose.h"

namespace graphslam::storage {

// `times_path` empty: stamps are the frame indices 0, 1, 2, ...
StatusOr<std::vector<StampedPose3>> ReadKittiPoses(const std::string& path,
                                                   const std::string& times_path = "");

// The pose in the vehicle convention (above).
StampedPose3 KittiCameraToBody(const StampedPose3& camera);

}  // namespace graphslam::storage
