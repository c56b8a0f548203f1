#include "core/pose_factors_3d.h"

#include <algorithm>

#include "core/check.h"
#include "core/gps3_model.h"
#include "core/internal/robust_term.h"
#include "core/relative_pose3_model.h"

namespace graphslam::core {

using internal::RobustTerm;

namespace {

constexpr int kDim = 6;
using Matrix36 = Eigen::Matrix<double, 3, 6>;

}  // namespace

double PoseFactorsChi2(const Problem3d& problem, const std::vector<Pose3>& poses,
                       const PoseFactorKernels& kernels) {
  double chi2 = 0.0;
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    Vector6d e;
    EvaluateRelativePose3(poses[c.from], poses[c.to], c.z, &e, nullptr, nullptr);
    chi2 += RobustTerm<6>(kernels.relative_pose, e, c.information, nullptr);
  }
  for (const Gps3Constraint& c : problem.gps) {
    Eigen::Vector3d e;
    EvaluateGps3(poses[c.pose], c.z, &e, nullptr);
    chi2 += RobustTerm<3>(kernels.gps, e, c.information, nullptr);
  }
  return chi2;
}

double LinearizePoseFactors(const Problem3d& problem, const std::vector<Pose3>& poses,
                            const UnknownLayout& layout, BlockSparseMatrix* hessian,
                            Eigen::VectorXd* gradient, Eigen::VectorXd* hessian_diagonal,
                            const PoseFactorKernels& kernels) {
  double chi2 = 0.0;
  Vector6d e;
  Matrix6d ja, jb, w;
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    EvaluateRelativePose3(poses[c.from], poses[c.to], c.z, &e, &ja, &jb);
    chi2 += RobustTerm<6>(kernels.relative_pose, e, c.information, &w);
    const int32_t ua = layout.unknown_index[c.from];
    const int32_t ub = layout.unknown_index[c.to];
    const Matrix6d wa = ja.transpose() * w;
    const Matrix6d wb = jb.transpose() * w;
    if (ua >= 0) {
      const Matrix6d haa = wa * ja;
      GS_CHECK(hessian->AddBlock(ua, ua, haa));
      gradient->segment<kDim>(kDim * ua) += wa * e;
      hessian_diagonal->segment<kDim>(kDim * ua) += haa.diagonal();
    }
    if (ub >= 0) {
      const Matrix6d hbb = wb * jb;
      GS_CHECK(hessian->AddBlock(ub, ub, hbb));
      gradient->segment<kDim>(kDim * ub) += wb * e;
      hessian_diagonal->segment<kDim>(kDim * ub) += hbb.diagonal();
    }
    if (ua >= 0 && ub >= 0 && ua != ub) {
      // Store the upper block (row < column); AddBlock mirrors it.
      if (ua < ub) {
        GS_CHECK(hessian->AddBlock(ua, ub, Matrix6d(wa * jb)));
      } else {
        GS_CHECK(hessian->AddBlock(ub, ua, Matrix6d(wb * ja)));
      }
    }
  }
  Eigen::Vector3d e3;
  Matrix36 j3;
  Eigen::Matrix3d w3;
  for (const Gps3Constraint& c : problem.gps) {
    EvaluateGps3(poses[c.pose], c.z, &e3, &j3);
    chi2 += RobustTerm<3>(kernels.gps, e3, c.information, &w3);
    const int32_t u = layout.unknown_index[c.pose];
    if (u < 0) continue;
    const Eigen::Matrix<double, 6, 3> wj = j3.transpose() * w3;
    const Matrix6d h = wj * j3;
    GS_CHECK(hessian->AddBlock(u, u, h));
    gradient->segment<kDim>(kDim * u) += wj * e3;
    hessian_diagonal->segment<kDim>(kDim * u) += h.diagonal();
  }
  return chi2;
}

void AppendPoseFactorPattern(const Problem3d& problem, const UnknownLayout& layout,
                             std::vector<std::pair<int, int>>* pairs) {
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    const int32_t ua = layout.unknown_index[c.from], ub = layout.unknown_index[c.to];
    if (ua >= 0 && ub >= 0) pairs->emplace_back(std::min(ua, ub), std::max(ua, ub));
  }
}

}  // namespace graphslam::core
