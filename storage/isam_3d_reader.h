// Reads a 3-D iSAM file (Kaess et al., iSAM; the records of iSAM's Loader)
// into a core::Problem3d.
//
//   EDGE3  i j x y z roll pitch yaw [S(21)]   -> relative pose, pose j in frame of i
//   POINT3 i l x y z [S(6)]                   -> point l in the frame of pose i
// The rotation is R = Rz(yaw) Ry(pitch) Rx(roll) (iSAM's Pose3d(x, y, z, yaw,
// pitch, roll)). S is the UPPER-TRIANGULAR SQUARE-ROOT information, row first,
// over (x, y, z, roll, pitch, yaw) for EDGE3 (README.isam-data.txt); the
// information is Omega = S^T S (identity when S is omitted), stated on
// (x, y, z, roll, pitch, yaw) of the error pose. Our relative-pose error
// [t; vec(q)] (g2o's) has vec(q) = (roll, pitch, yaw)/2 to first order at the
// identity, so the rotation rows and columns of Omega are scaled by 2 each:
// Omega' = K Omega K, K = diag(1, 1, 1, 2, 2, 2) (same chi2 to second order).
//
// iSAM files carry no initial guesses: poses are created in order of first
// mention, uninitialized (core::InitializeProblem3d chains the odometry).
// iSAM ties the first pose to the origin with a prior; here the first pose is
// the gauge anchor instead (pose 0 of the problem). 2-D records (EDGE2,
// ODOMETRY, LANDMARK) are NotSupported; errors name file:line. A singular S
// is rejected, or with `repairs` (opt-in) Omega is repaired
// (core/information_repair.h) and counted there.
//
// THREAD SAFETY: reentrant. ALLOCATION: O(records).
#pragma once

#include <string>

#include "core/information_repair.h"
#include "core/problem_3d.h"
#include "core/status.h"

namespace graphslam::storage {

StatusOr<core::Problem3d> ReadIsam3d(const std::string& path,
                                     core::InformationRepairs* repairs = nullptr);

// The rotation of iSAM's Pose3d from (roll, pitch, yaw).
Eigen::Quaterniond QuaternionFromRollPitchYaw(double roll, double pitch, double yaw);

}  // namespace graphslam::storage
