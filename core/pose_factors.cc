// The planar pose-only factors (core/pose_factors.h). The planar models are
// differentiated w.r.t. (x, y, theta); RetractionJacobian carries each
// Jacobian to the increment after evaluation.
#include "core/pose_factors.h"

#include "core/gps_model.h"
#include "core/internal/pose_factor_sums.h"
#include "core/interpolated_pose_range_bearing_model.h"
#include "core/pose_range_bearing_model.h"
#include "core/relative_pose_model.h"
#include "core/velocity_motion_model.h"

namespace graphslam::core {
namespace {

using internal::PoseFactor;
using internal::TernaryPoseFactor;

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
// Interpolated sightings (to_next >= 0) are the three-pose factor's.
bool PoseRangeBearing(const PoseRangeBearingConstraint& c, const Pose2& from, const Pose2& to,
                      Eigen::Vector2d* e, Jacobian23* ja, Jacobian23* jb) {
  if (c.interpolated()) return false;
  return EvaluatePoseRangeBearing(from, to, c.z, e, ja, jb);
}

// The observed robot's position interpolated between `to` and `to_next`.
bool InterpolatedPoseRangeBearing(const PoseRangeBearingConstraint& c,
                                  const std::vector<Pose2>& poses, Eigen::Vector2d* e,
                                  Jacobian23* ja, Jacobian23* jb, Jacobian23* jc) {
  if (!c.interpolated()) return false;
  if (!EvaluateInterpolatedPoseRangeBearing(poses[c.from], poses[c.to], poses[c.to_next], c.alpha,
                                            c.z, e, ja, jb, jc))
    return false;
  ToIncrement(poses[c.from], ja);
  ToIncrement(poses[c.to], jb);
  ToIncrement(poses[c.to_next], jc);
  return true;
}

bool Gps(const GpsConstraint& c, const std::vector<Pose2>& poses, Eigen::Vector2d* e,
         Jacobian23* j, Jacobian23* /*unused*/) {
  EvaluateGps(poses[c.pose], c.z, e, j);
  ToIncrement(poses[c.pose], j);
  return true;
}

template <class C, int kResidual, auto Model>
using PlanarBinaryFactor = PoseFactor<C, kResidual, 3, PlanarBinary<C, kResidual, Model>>;
// The normal-equation blocks of a relative pose from the pieces of its
// Jacobians (core/relative_pose_model.h): with J_i = [ -q u ; 0 0 -1 ],
// J_j = [ g 0 ; 0 0 1 ] and W = rho'(s) Omega = [ a b_c ; b_r w_22 ],
//   W J_j = [ a g  b_c ; b_r g  w_22 ],   W J_i = [ -a q  a u - b_c ; -b_r q  b_r u - w_22 ],
// and J^T (W J) by the zero blocks of J: 2x2 products only.
struct RelativePoseFactor : PoseFactor<RelativePoseConstraint, 3, 3, RelativePose> {
  static double Linearize(const RelativePoseConstraint& c, const std::vector<Pose2>& poses,
                          const RobustKernel& kernel, internal::PoseFactorSink<3>* sink) {
    Eigen::Vector3d e;
    RelativePoseIncrementFactors f;
    EvaluateRelativePoseIncrementFactors(poses[c.from], poses[c.to], c.z, &e, &f);
    Eigen::Matrix3d w;
    const double chi2 = internal::RobustTerm<3>(kernel, e, c.information, &w);
    const Eigen::Matrix2d a = w.topLeftCorner<2, 2>();
    const Eigen::Vector2d b_c = w.topRightCorner<2, 1>();
    const Eigen::RowVector2d b_r = w.bottomLeftCorner<1, 2>();
    const double w22 = w(2, 2);
    const Eigen::Matrix2d ag = a * f.g;
    const Eigen::Matrix2d aq = a * f.q;
    const Eigen::Vector2d au = a * f.u - b_c;  // W J_i, top right
    const double bu = b_r.dot(f.u) - w22;      // W J_i, bottom right
    const Eigen::Matrix2d qt = f.q.transpose();
    Eigen::Matrix3d h_ii, h_jj, h_ij;
    h_ii.topLeftCorner<2, 2>() = qt * aq;
    h_ii.topRightCorner<2, 1>() = -(qt * au);
    h_ii.bottomLeftCorner<1, 2>() = b_r * f.q - f.u.transpose() * aq;
    h_ii(2, 2) = f.u.dot(au) - bu;
    h_jj.topLeftCorner<2, 2>() = f.g.transpose() * ag;
    h_jj.topRightCorner<2, 1>() = f.g.transpose() * b_c;
    h_jj.bottomLeftCorner<1, 2>() = b_r * f.g;
    h_jj(2, 2) = w22;
    h_ij.topLeftCorner<2, 2>() = -(qt * ag);
    h_ij.topRightCorner<2, 1>() = -(qt * b_c);
    h_ij.bottomLeftCorner<1, 2>() = f.u.transpose() * ag - b_r * f.g;
    h_ij(2, 2) = f.u.dot(b_c) - w22;
    const Eigen::Vector3d we = w * e;
    Eigen::Vector3d g_i, g_j;
    g_i.head<2>() = -(qt * we.head<2>());
    g_i.z() = f.u.dot(we.head<2>()) - we.z();
    g_j.head<2>() = f.g.transpose() * we.head<2>();
    g_j.z() = we.z();
    sink->AddBinaryBlocks(c.from, c.to, h_ii, h_jj, h_ij, g_i, g_j);
    return chi2;
  }
};
using VelocityMotionFactor = PlanarBinaryFactor<VelocityMotionConstraint, 3, VelocityMotion>;
using PoseRangeBearingFactor = PlanarBinaryFactor<PoseRangeBearingConstraint, 2, PoseRangeBearing>;
using InterpolatedPoseRangeBearingFactor =
    TernaryPoseFactor<PoseRangeBearingConstraint, 2, 3, InterpolatedPoseRangeBearing>;
using GpsFactor = PoseFactor<GpsConstraint, 2, 3, Gps>;

}  // namespace

template <>
struct internal::PoseFactorList<Problem2d>
    : internal::PoseFactorTable<
          internal::PoseFactorEntry<RelativePoseFactor, &Problem2d::relative_poses,
                                    &PoseFactorKernels::relative_pose>,
          internal::PoseFactorEntry<VelocityMotionFactor, &Problem2d::motions,
                                    &PoseFactorKernels::motion>,
          internal::PoseFactorEntry<GpsFactor, &Problem2d::gps, &PoseFactorKernels::gps>,
          internal::PoseFactorEntry<PoseRangeBearingFactor, &Problem2d::pose_range_bearings,
                                    &PoseFactorKernels::robot>,
          internal::PoseFactorEntry<InterpolatedPoseRangeBearingFactor,
                                    &Problem2d::pose_range_bearings, &PoseFactorKernels::robot>> {};

GS_INSTANTIATE_POSE_FACTORS(Problem2d);

}  // namespace graphslam::core
