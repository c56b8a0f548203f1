#include "core/pose_factors.h"

#include "core/check.h"
#include "core/gps_model.h"
#include "core/internal/robust_term.h"
#include "core/pose_range_bearing_model.h"
#include "core/relative_pose_model.h"
#include "core/velocity_motion_model.h"

namespace graphslam::core {

using internal::RobustTerm;

namespace {

constexpr int kDim = UnknownLayout::kPoseDimension;

// Adds A_a^T W A_b for every pair of touched unknown poses, and the gradients.
template <int kResidual>
void AddBinary(const UnknownLayout& layout, int32_t pose_a, int32_t pose_b,
               const Eigen::Matrix<double, kResidual, 3>& jacobian_a,
               const Eigen::Matrix<double, kResidual, 3>& jacobian_b,
               const Eigen::Matrix<double, kResidual, kResidual>& information,
               const Eigen::Matrix<double, kResidual, 1>& residual, BlockSparseMatrix* hessian,
               Eigen::VectorXd* gradient, Eigen::VectorXd* hessian_diagonal) {
  const int32_t ua = layout.unknown_index[pose_a];
  const int32_t ub = layout.unknown_index[pose_b];
  const Eigen::Matrix<double, 3, kResidual> wa = jacobian_a.transpose() * information;
  const Eigen::Matrix<double, 3, kResidual> wb = jacobian_b.transpose() * information;
  if (ua >= 0) {
    const Eigen::Matrix3d haa = wa * jacobian_a;
    GS_CHECK(hessian->AddBlock(ua, ua, haa));
    gradient->segment<kDim>(kDim * ua) += wa * residual;
    hessian_diagonal->segment<kDim>(kDim * ua) += haa.diagonal();
  }
  if (ub >= 0) {
    const Eigen::Matrix3d hbb = wb * jacobian_b;
    GS_CHECK(hessian->AddBlock(ub, ub, hbb));
    gradient->segment<kDim>(kDim * ub) += wb * residual;
    hessian_diagonal->segment<kDim>(kDim * ub) += hbb.diagonal();
  }
  if (ua >= 0 && ub >= 0 && ua != ub) {
    // Store the upper block (row < column); AddBlock mirrors it.
    if (ua < ub) {
      GS_CHECK(hessian->AddBlock(ua, ub, Eigen::Matrix3d(wa * jacobian_b)));
    } else {
      GS_CHECK(hessian->AddBlock(ub, ua, Eigen::Matrix3d(wb * jacobian_a)));
    }
  }
}

}  // namespace

double PoseFactorsChi2(const Problem2d& problem, const std::vector<Pose2>& poses,
                       const PoseFactorKernels& kernels) {
  double chi2 = 0.0;
  Eigen::Vector3d e3;
  for (const RelativePoseConstraint& c : problem.relative_poses) {
    EvaluateRelativePose(poses[c.from], poses[c.to], c.z, &e3, nullptr, nullptr);
    chi2 += RobustTerm<3>(kernels.relative_pose, e3, c.information, nullptr);
  }
  for (const VelocityMotionConstraint& c : problem.motions) {
    EvaluateVelocityMotion(poses[c.from], poses[c.to], c.control, &e3, nullptr, nullptr);
    chi2 += RobustTerm<3>(kernels.motion, e3, c.information, nullptr);
  }
  Eigen::Vector2d e2;
  for (const GpsConstraint& c : problem.gps) {
    EvaluateGps(poses[c.pose], c.z, &e2, nullptr);
    chi2 += RobustTerm<2>(kernels.gps, e2, c.information, nullptr);
  }
  for (const PoseRangeBearingConstraint& c : problem.pose_range_bearings) {
    // Coincident positions (undefined bearing) contribute nothing, as an
    // observation at its feature's position does in the feature linearizer.
    if (!EvaluatePoseRangeBearing(poses[c.from], poses[c.to], c.z, &e2, nullptr, nullptr)) continue;
    chi2 += RobustTerm<2>(kernels.robot, e2, c.information, nullptr);
  }
  return chi2;
}

double LinearizePoseFactors(const Problem2d& problem, const std::vector<Pose2>& poses,
                            const UnknownLayout& layout, BlockSparseMatrix* hessian,
                            Eigen::VectorXd* gradient, Eigen::VectorXd* hessian_diagonal,
                            const PoseFactorKernels& kernels) {
  double chi2 = 0.0;
  Eigen::Vector3d e3;
  Eigen::Matrix3d ja, jb, w3;
  for (const RelativePoseConstraint& c : problem.relative_poses) {
    EvaluateRelativePose(poses[c.from], poses[c.to], c.z, &e3, &ja, &jb);
    chi2 += RobustTerm<3>(kernels.relative_pose, e3, c.information, &w3);
    ja = ja * RetractionJacobian(poses[c.from]);
    jb = jb * RetractionJacobian(poses[c.to]);
    AddBinary<3>(layout, c.from, c.to, ja, jb, w3, e3, hessian, gradient, hessian_diagonal);
  }
  for (const VelocityMotionConstraint& c : problem.motions) {
    EvaluateVelocityMotion(poses[c.from], poses[c.to], c.control, &e3, &ja, &jb);
    chi2 += RobustTerm<3>(kernels.motion, e3, c.information, &w3);
    ja = ja * RetractionJacobian(poses[c.from]);
    jb = jb * RetractionJacobian(poses[c.to]);
    AddBinary<3>(layout, c.from, c.to, ja, jb, w3, e3, hessian, gradient, hessian_diagonal);
  }
  Eigen::Vector2d e2;
  Eigen::Matrix<double, 2, 3> j2;
  Eigen::Matrix2d w2;
  for (const GpsConstraint& c : problem.gps) {
    EvaluateGps(poses[c.pose], c.z, &e2, &j2);
    chi2 += RobustTerm<2>(kernels.gps, e2, c.information, &w2);
    j2 = j2 * RetractionJacobian(poses[c.pose]);
    const int32_t u = layout.unknown_index[c.pose];
    if (u < 0) continue;
    const Eigen::Matrix<double, 3, 2> w = j2.transpose() * w2;
    const Eigen::Matrix3d h = w * j2;
    GS_CHECK(hessian->AddBlock(u, u, h));
    gradient->segment<kDim>(kDim * u) += w * e2;
    hessian_diagonal->segment<kDim>(kDim * u) += h.diagonal();
  }
  Eigen::Matrix<double, 2, 3> j2b;
  for (const PoseRangeBearingConstraint& c : problem.pose_range_bearings) {
    if (!EvaluatePoseRangeBearing(poses[c.from], poses[c.to], c.z, &e2, &j2, &j2b)) continue;
    chi2 += RobustTerm<2>(kernels.robot, e2, c.information, &w2);
    j2 = j2 * RetractionJacobian(poses[c.from]);
    j2b = j2b * RetractionJacobian(poses[c.to]);
    AddBinary<2>(layout, c.from, c.to, j2, j2b, w2, e2, hessian, gradient, hessian_diagonal);
  }
  return chi2;
}

void AppendPoseFactorPattern(const Problem2d& problem, const UnknownLayout& layout,
                             std::vector<std::pair<int, int>>* pairs) {
  auto add = [&](int32_t a, int32_t b) {
    const int32_t ua = layout.unknown_index[a], ub = layout.unknown_index[b];
    if (ua >= 0 && ub >= 0) pairs->emplace_back(std::min(ua, ub), std::max(ua, ub));
  };
  for (const RelativePoseConstraint& c : problem.relative_poses) add(c.from, c.to);
  for (const VelocityMotionConstraint& c : problem.motions) add(c.from, c.to);
  for (const PoseRangeBearingConstraint& c : problem.pose_range_bearings) add(c.from, c.to);
}

}  // namespace graphslam::core
