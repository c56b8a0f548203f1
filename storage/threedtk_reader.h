// 3DTK "uos" scan folders (slam6d, http://slam6d.sourceforge.net):
//
//   DIR/scanNNN.3d     one point a line: x y z [reflectance]   [cm]
//   DIR/scanNNN.pose   x y z (position, cm) then rx ry rz (Euler angles, degrees)
//
// 3DTK's frame is left-handed with y up (x right, z forward). Its pose is
// (3DTK src/slam6d/scan.cc, EulerToMatrix4 in globals.icc, column-major)
//
//   p_world = Rx(rx) Ry(ry) Rz(rz) p_scan + t.
//
// We convert to our right-handed metres with x forward, y left, z up (the ROS
// convention 3DTK's own exporters use):
//
//   C = [0 0 1; -1 0 0; 0 1 0]    (det C = -1: the handedness flip)
//   p = C p_3dtk / 100,  R = C R_3dtk C^T,  t = C t_3dtk / 100,
//
// so that p_world = R p + t holds in the new frame (R is a proper rotation:
// det = det(C)^2 det(R_3dtk) = 1).
//
// THREAD SAFETY: pure functions of the files. ALLOCATION: one scan.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"
#include "core/scan.h"

namespace graphslam::map {

// The scan numbers NNN present in DIR (a scanNNN.3d with its scanNNN.pose),
// ascending. NotFound if DIR has none.
StatusOr<std::vector<int>> List3dtkScans(const std::string& dir);

// Reads scan `number` of DIR, converted as above; scan.pose = `pose_index`.
// Corruption naming file:line on a malformed line, NotFound for a missing file.
StatusOr<Scan> Read3dtkScan(const std::string& dir, int number, int64_t pose_index);

// Rx(rx) Ry(ry) Rz(rz) (radians), 3DTK's rotation.
Eigen::Matrix3d ThreeDtkRotation(double rx, double ry, double rz);
// The frame change C above.
Eigen::Matrix3d ThreeDtkToRightHanded();

}  // namespace graphslam::map
