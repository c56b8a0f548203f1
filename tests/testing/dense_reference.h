// Dense reference math for a Problem2d: the stacked whitened residual vector of
// every constraint, its central-difference Jacobian, and a plain dense
// Gauss-Newton solve. Used to check the sparse, chunked, eliminated machinery.
//
//   state s = [free poses (3 each, UnknownLayout order); features (2 each)]
//   r(s) = stacked L^T e_k  with W_k = L L^T, so r^T r = sum e^T W e = chi2
//   H = J^T J,  g = J^T r       (J by central differences: independent of the
//                                analytic Jacobians under test)
// J is taken w.r.t. the solver's increment: a body-frame step for each pose,
// x (+) d = Compose(x, d) (core/se2.h RetractPose), and a plain step for features.
#pragma once

#include <Eigen/Cholesky>
#include <Eigen/Dense>
#include <vector>

#include "core/gps_model.h"
#include "core/observation_models.h"
#include "core/problem.h"
#include "core/relative_pose_model.h"
#include "core/unknown_layout.h"
#include "core/velocity_motion_model.h"
#include "tests/testing/numeric_diff.h"

namespace graphslam::testing {

class DenseReference {
 public:
  explicit DenseReference(const core::Problem2d& problem)
      : problem_(problem), layout_(core::UnknownLayout::FromProblem(problem)) {}

  int num_pose_unknowns() const { return 3 * layout_.num_unknown_poses; }
  int num_unknowns() const { return num_pose_unknowns() + 2 * problem_.num_features(); }

  Eigen::VectorXd State() const {
    Eigen::VectorXd s(num_unknowns());
    for (int p = 0; p < problem_.num_poses(); ++p)
      if (layout_.unknown_index[p] >= 0) s.segment<3>(3 * layout_.unknown_index[p]) = problem_.poses[p];
    for (int j = 0; j < problem_.num_features(); ++j)
      s.segment<2>(num_pose_unknowns() + 2 * j) = problem_.features[j];
    return s;
  }

  void Unpack(const Eigen::VectorXd& s, std::vector<core::Pose2>* poses,
              std::vector<core::Point2>* features) const {
    *poses = problem_.poses;
    *features = problem_.features;
    for (int p = 0; p < problem_.num_poses(); ++p)
      if (layout_.unknown_index[p] >= 0) (*poses)[p] = s.segment<3>(3 * layout_.unknown_index[p]);
    for (int j = 0; j < problem_.num_features(); ++j)
      (*features)[j] = s.segment<2>(num_pose_unknowns() + 2 * j);
  }

  Eigen::VectorXd Residual(const Eigen::VectorXd& s) const {
    std::vector<core::Pose2> x;
    std::vector<core::Point2> m;
    Unpack(s, &x, &m);
    std::vector<double> r;
    auto push = [&](const Eigen::VectorXd& e, const Eigen::MatrixXd& w) {
      const Eigen::MatrixXd l = Eigen::LLT<Eigen::MatrixXd>(w).matrixL();
      const Eigen::VectorXd white = l.transpose() * e;
      r.insert(r.end(), white.data(), white.data() + white.size());
    };
    Eigen::Vector3d e3;
    Eigen::Vector2d e2;
    for (const auto& c : problem_.relative_poses) {
      core::EvaluateRelativePose(x[c.from], x[c.to], c.z, &e3, nullptr, nullptr);
      push(e3, c.information);
    }
    for (const auto& c : problem_.motions) {
      core::EvaluateVelocityMotion(x[c.from], x[c.to], c.control, &e3, nullptr, nullptr);
      push(e3, c.information);
    }
    for (const auto& c : problem_.gps) {
      core::EvaluateGps(x[c.pose], c.z, &e2, nullptr);
      push(e2, c.information);
    }
    for (const auto& o : problem_.observations) {
      core::EvaluateObservation(o.kind, x[o.pose], m[o.feature], o.z, &e2, nullptr, nullptr);
      push(e2, o.information);
    }
    return Eigen::Map<Eigen::VectorXd>(r.data(), static_cast<int>(r.size()));
  }

  double Chi2(const Eigen::VectorXd& s) const { return Residual(s).squaredNorm(); }

  // s (+) d: body-frame steps for poses, additive for features.
  Eigen::VectorXd Retract(const Eigen::VectorXd& s, const Eigen::VectorXd& d) const {
    Eigen::VectorXd out = s + d;
    for (int u = 0; u < layout_.num_unknown_poses; ++u)
      out.segment<3>(3 * u) = core::RetractPose(s.segment<3>(3 * u), d.segment<3>(3 * u));
    return out;
  }

  // H = J^T J and g = J^T r at s, J = d r(s (+) d) / d d at d = 0.
  void Linearize(const Eigen::VectorXd& s, Eigen::MatrixXd* hessian, Eigen::VectorXd* gradient) const {
    const Eigen::MatrixXd j = NumericJacobian(
        [this, &s](const Eigen::VectorXd& d) { return Residual(Retract(s, d)); },
        Eigen::VectorXd::Zero(s.size()));
    *hessian = j.transpose() * j;
    *gradient = j.transpose() * Residual(s);
  }

  // Dense Gauss-Newton from the problem's state; returns the final state.
  Eigen::VectorXd SolveGaussNewton(int iterations) const {
    Eigen::VectorXd s = State();
    for (int it = 0; it < iterations; ++it) {
      Eigen::MatrixXd h;
      Eigen::VectorXd g;
      Linearize(s, &h, &g);
      const Eigen::VectorXd step = h.ldlt().solve(-g);
      s = Retract(s, step);
      if (step.norm() < 1e-12) break;
    }
    return s;
  }

  const core::UnknownLayout& layout() const { return layout_; }

 private:
  const core::Problem2d& problem_;
  core::UnknownLayout layout_;
};

}  // namespace graphslam::testing
