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

// The normal-equation blocks of a relative pose from the factors of its
// Jacobians (core/relative_pose_3d_model.h): with J_j = D = diag(d_t, d_q),
// J_i = -D A, A = [r s; 0 r] and W = rho'(s) Omega,
//   h_jj = D^T W D,   P = h_jj A,   h_ii = A^T P,   h_ij = -A^T h_jj = -P^T,
//   g_j = D^T W e,    g_i = -A^T g_j,
// products of 3x3 blocks that skip the zero blocks of D and A: about 540
// multiply-adds where the dense 6x6 products (J_i itself, then W J_i, W J_j
// and three blocks) take about 1 300.
struct RelativePose3Factor : PoseFactor<RelativePose3Constraint, 6, 6, RelativePose3> {
  static double Linearize(const RelativePose3Constraint& c, const std::vector<Pose3>& poses,
                          const RobustKernel& kernel, internal::PoseFactorSink<6>* sink) {
    using Eigen::Matrix3d;
    Vector6d e;
    RelativePose3Factors f;
    EvaluateRelativePose3Factors(poses[c.from], poses[c.to], c.z, &e, &f);
    Matrix6d w;
    const double chi2 = internal::RobustTerm<6>(kernel, e, c.information, &w);
    Matrix6d wd;  // W D (= (D^T W)^T, W symmetric)
    wd.leftCols<3>().noalias() = w.leftCols<3>() * f.d_t;
    wd.rightCols<3>().noalias() = w.rightCols<3>() * f.d_q;
    Matrix6d h_jj;
    h_jj.topRows<3>().noalias() = f.d_t.transpose() * wd.topRows<3>();
    h_jj.bottomRows<3>().noalias() = f.d_q.transpose() * wd.bottomRows<3>();
    const Vector6d g_j = wd.transpose() * e;
    Matrix6d p;
    p.leftCols<3>().noalias() = h_jj.leftCols<3>() * f.r;
    p.rightCols<3>().noalias() = h_jj.leftCols<3>() * f.s;
    p.rightCols<3>().noalias() += h_jj.rightCols<3>() * f.r;
    Matrix6d h_ii;
    h_ii.topRows<3>().noalias() = f.r.transpose() * p.topRows<3>();
    h_ii.bottomRows<3>().noalias() = f.s.transpose() * p.topRows<3>();
    h_ii.bottomRows<3>().noalias() += f.r.transpose() * p.bottomRows<3>();
    Vector6d g_i;
    g_i.head<3>().noalias() = -(f.r.transpose() * g_j.head<3>());
    g_i.tail<3>().noalias() = -(f.s.transpose() * g_j.head<3>() + f.r.transpose() * g_j.tail<3>());
    const Matrix6d h_ij = -p.transpose();
    sink->AddBinaryBlocks(c.from, c.to, h_ii, h_jj, h_ij, g_i, g_j);
    return chi2;
  }
};
using Gps3Factor = PoseFactor<Gps3Constraint, 3, 6, Gps3>;

}  // namespace

template <>
struct internal::PoseFactorList<Problem3d>
    : internal::PoseFactorTable<
          internal::PoseFactorEntry<RelativePose3Factor, &Problem3d::relative_poses,
                                    &PoseFactorKernels::relative_pose>,
          internal::PoseFactorEntry<Gps3Factor, &Problem3d::gps, &PoseFactorKernels::gps>> {};

GS_INSTANTIATE_POSE_FACTORS(Problem3d);

}  // namespace graphslam::core
