// The planar pose-only factors (core/pose_factors.h). The planar models are
// differentiated w.r.t. (x, y, theta); RetractionJacobian carries each
// Jacobian to the increment after evaluation.
#include "core/pose_factors.h"

#include "core/gps_model.h"
#include "core/internal/pose_factor_sums.h"
#include "core/pose_range_bearing_model.h"
#include "core/relative_pose_model.h"
#include "core/velocity_motion_model.h"

namespace graphslam::core {
namespace {

using internal::PoseFactor;

using Jacobian23 = Eigen::Matrix<double, 2, 3>;

// j <- j * dx/dd at `pose`, when the Jacobian is wanted.
template <class Jacobian>
void ToIncrement(const Pose2& pose, Jacobian* jacobian) {
  if (jacobian != nullptr) *jacobian = *jacobian * RetractionJacobian(pose);
}

// A planar model between two poses: Model(c, from, to, e, j_from, j_to),
// carried to the increments.
template <class C, int kResidual, auto Model>
bool PlanarBinary(const C& c, const std::vector<Pose2>& poses,
                  Eigen::Matrix<double, kResidual, 1>* e, Eigen::Matrix<double, kResidual, 3>* ja,
                  Eigen::Matrix<double, kResidual, 3>* jb) {
  if (!Model(c, poses[c.from], poses[c.to], e, ja, jb)) return false;
  ToIncrement(poses[c.from], ja);
  ToIncrement(poses[c.to], jb);
  return true;
}

// Differentiated w.r.t. the increments directly (fewer sine-cosine pairs
// than the (x, y, theta) Jacobians carried by ToIncrement).
bool RelativePose(const RelativePoseConstraint& c, const std::vector<Pose2>& poses,
                  Eigen::Vector3d* e, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb) {
  EvaluateRelativePoseIncrement(poses[c.from], poses[c.to], c.z, e, ja, jb);
  return true;
}

bool VelocityMotion(const VelocityMotionConstraint& c, const Pose2& from, const Pose2& to,
                    Eigen::Vector3d* e, Eigen::Matrix3d* ja, Eigen::Matrix3d* jb) {
  EvaluateVelocityMotion(from, to, c.control, e, ja, jb);
  return true;
}

// Coincident positions (undefined bearing) contribute nothing, as an
// observation at its feature's position does in the feature linearizer.
bool PoseRangeBearing(const PoseRangeBearingConstraint& c, const Pose2& from, const Pose2& to,
                      Eigen::Vector2d* e, Jacobian23* ja, Jacobian23* jb) {
  return EvaluatePoseRangeBearing(from, to, c.z, e, ja, jb);
}

bool Gps(const GpsConstraint& c, const std::vector<Pose2>& poses, Eigen::Vector2d* e,
         Jacobian23* j, Jacobian23* /*unused*/) {
  EvaluateGps(poses[c.pose], c.z, e, j);
  ToIncrement(poses[c.pose], j);
  return true;
}

template <class C, int kResidual, auto Model>
using PlanarBinaryFactor = PoseFactor<C, kResidual, 3, PlanarBinary<C, kResidual, Model>>;
using RelativePoseFactor = PoseFactor<RelativePoseConstraint, 3, 3, RelativePose>;
using VelocityMotionFactor = PlanarBinaryFactor<VelocityMotionConstraint, 3, VelocityMotion>;
using PoseRangeBearingFactor = PlanarBinaryFactor<PoseRangeBearingConstraint, 2, PoseRangeBearing>;
using GpsFactor = PoseFactor<GpsConstraint, 2, 3, Gps>;

}  // namespace

template <>
struct internal::PoseFactorList<Problem2d> {
  template <class Visit>
  static void ForEach(const Problem2d& problem, const PoseFactorKernels& kernels, Visit&& visit) {
    visit(RelativePoseFactor{}, problem.relative_poses, kernels.relative_pose);
    visit(VelocityMotionFactor{}, problem.motions, kernels.motion);
    visit(GpsFactor{}, problem.gps, kernels.gps);
    visit(PoseRangeBearingFactor{}, problem.pose_range_bearings, kernels.robot);
  }
};

GS_INSTANTIATE_POSE_FACTORS(Problem2d);

}  // namespace graphslam::core
