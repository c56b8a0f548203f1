// The 3-D pose-only factors (core/pose_factors.h). The SE(3) models give
// their Jacobians w.r.t. the body-frame increments already (x Exp(d)).
#include "core/gps_3d_model.h"
#include "core/internal/pose_factor_sums.h"
#include "core/pose_factors.h"
#include "core/relative_pose_3d_model.h"

namespace graphslam::core {
namespace {

using internal::PoseFactor;

bool RelativePose3(const RelativePose3Constraint& c, const std::vector<Pose3>& poses, Vector6d* e,
                   Matrix6d* ja, Matrix6d* jb) {
  EvaluateRelativePose3(poses[c.from], poses[c.to], c.z, e, ja, jb);
  return true;
}

bool Gps3(const Gps3Constraint& c, const std::vector<Pose3>& poses, Eigen::Vector3d* e,
          Eigen::Matrix<double, 3, 6>* j, Eigen::Matrix<double, 3, 6>* /*unused*/) {
  EvaluateGps3(poses[c.pose], c.z, e, j);
  return true;
}

using RelativePose3Factor = PoseFactor<RelativePose3Constraint, 6, 6, RelativePose3>;
using Gps3Factor = PoseFactor<Gps3Constraint, 3, 6, Gps3>;

}  // namespace

template <>
struct internal::PoseFactorList<Problem3d> {
  template <class Visit>
  static void ForEach(const Problem3d& problem, const PoseFactorKernels& kernels, Visit&& visit) {
    visit(RelativePose3Factor{}, problem.relative_poses, kernels.relative_pose);
    visit(Gps3Factor{}, problem.gps, kernels.gps);
  }
};

GS_INSTANTIATE_POSE_FACTORS(Problem3d);

}  // namespace graphslam::core
