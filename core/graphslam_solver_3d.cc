#include "core/graphslam_solver_3d.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <utility>

#include "core/block_jacobi_preconditioner.h"
#include "core/block_sparse_matrix.h"
#include "core/chunk_passes.h"
#include "core/cholmod_solver.h"
#include "core/gps3_model.h"
#include "core/incomplete_cholesky_preconditioner.h"
#include "core/logging.h"
#include "core/point3_observation_model.h"
#include "core/preconditioned_conjugate_gradient.h"
#include "core/relative_pose3_model.h"
#include "core/schur_eliminator.h"

namespace graphslam::core {
namespace {

constexpr int kPoseDim = 6;
constexpr int kPointDim = 3;
using Clock = std::chrono::steady_clock;
using Matrix36 = Eigen::Matrix<double, 3, 6>;
using Matrix63 = Eigen::Matrix<double, 6, 3>;

double SecondsSince(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Which poses are unknowns (block index) and which are anchors (-1).
std::vector<int32_t> MakeLayout(const Problem3d& problem, int32_t* num_unknown) {
  const int32_t n = problem.num_poses();
  std::vector<uint8_t> fixed(problem.pose_fixed.begin(), problem.pose_fixed.end());
  const bool any_fixed = std::any_of(fixed.begin(), fixed.end(), [](uint8_t f) { return f != 0; });
  if (!any_fixed && problem.gps.empty() && n > 0) fixed[0] = 1;
  std::vector<int32_t> index(n, -1);
  *num_unknown = 0;
  for (int32_t p = 0; p < n; ++p)
    if (!fixed[p]) index[p] = (*num_unknown)++;
  return index;
}

// The linearized, reduced system of one iteration.
struct Linearization {
  BlockSparseMatrix matrix;      // S (before damping of the poses)
  Eigen::VectorXd rhs;           // -g_x + sum H_xj C_j^-1 g_j
  Eigen::VectorXd gradient;      // g_x
  Eigen::VectorXd hessian_diagonal;  // diag(H_xx)
  std::vector<FeatureBlocks> features;  // per feature (empty poses if not solved)
  std::vector<Eigen::Vector3d> feature_damping;  // D_j
};

class Solver3d {
 public:
  Solver3d(const SolverOptions& options, Problem3d* problem)
      : options_(options), problem_(*problem) {}

  Status Run(SolverSummary* summary);

 private:
  void Linearize(const std::vector<Pose3>& poses, const std::vector<Point3>& features,
                 double lambda, Linearization* out, ReducedContribution* scratch, Status* status);
  Status SolveReduced(const BlockSparseMatrix& matrix, const Eigen::VectorXd& rhs,
                      Eigen::VectorXd* x, int* iterations);

  const SolverOptions& options_;
  Problem3d& problem_;
  std::vector<int32_t> unknown_;
  int32_t num_unknown_ = 0;
  std::vector<std::vector<int32_t>> observations_of_feature_;
  LinearSolverType type_ = LinearSolverType::kCholmod;
  CholmodSolver cholmod_;
  BlockJacobiPreconditioner block_jacobi_;
  IncompleteCholeskyPreconditioner incomplete_cholesky_;
};

Status Solver3d::SolveReduced(const BlockSparseMatrix& matrix, const Eigen::VectorXd& rhs,
                              Eigen::VectorXd* x, int* iterations) {
  x->setZero(rhs.size());
  *iterations = 0;
  if (rhs.size() == 0) return Status::Ok();
  if (type_ == LinearSolverType::kCholmod) {
    GS_RETURN_IF_ERROR(cholmod_.Factorize(matrix));
    GS_RETURN_IF_ERROR(cholmod_.Solve(rhs, x));
    *iterations = 1;
    return Status::Ok();
  }
  const LinearOperator* preconditioner = &block_jacobi_;
  if (options_.preconditioner == PreconditionerType::kIncompleteCholesky) {
    GS_RETURN_IF_ERROR(incomplete_cholesky_.Update(matrix));
    preconditioner = &incomplete_cholesky_;
  } else {
    GS_RETURN_IF_ERROR(block_jacobi_.Update(matrix));
  }
  PcgOptions pcg;
  pcg.max_iterations = options_.pcg_max_iterations;
  pcg.relative_tolerance = options_.pcg_relative_tolerance;
  const PcgSummary summary = SolvePcg(matrix, *preconditioner, rhs, pcg, x);
  *iterations = summary.iterations;
  if (!x->allFinite()) return Status::Numerical("PCG produced a non-finite step");
  return Status::Ok();
}

void Solver3d::Linearize(const std::vector<Pose3>& poses, const std::vector<Point3>& features,
                         double lambda, Linearization* out, ReducedContribution* scratch,
                         Status* status) {
  *status = Status::Ok();
  out->matrix.SetZero();
  const int rows = out->matrix.num_rows();
  out->gradient.setZero(rows);
  out->hessian_diagonal.setZero(rows);

  // Relative poses.
  for (const RelativePose3Constraint& c : problem_.relative_poses) {
    Vector6d e;
    Matrix6d ji, jj;
    EvaluateRelativePose3(poses[c.from], poses[c.to], c.z, &e, &ji, &jj);
    const int32_t ui = unknown_[c.from], uj = unknown_[c.to];
    const Matrix6d wji = c.information * ji, wjj = c.information * jj;
    if (ui >= 0) {
      out->matrix.AddBlock(ui, ui, ji.transpose() * wji);
      out->gradient.segment<kPoseDim>(kPoseDim * ui) += ji.transpose() * (c.information * e);
    }
    if (uj >= 0) {
      out->matrix.AddBlock(uj, uj, jj.transpose() * wjj);
      out->gradient.segment<kPoseDim>(kPoseDim * uj) += jj.transpose() * (c.information * e);
    }
    if (ui >= 0 && uj >= 0 && ui != uj) out->matrix.AddBlock(ui, uj, ji.transpose() * wjj);
  }
  // GPS.
  for (const Gps3Constraint& c : problem_.gps) {
    const int32_t u = unknown_[c.pose];
    if (u < 0) continue;
    Eigen::Vector3d e;
    Matrix36 j;
    EvaluateGps3(poses[c.pose], c.z, &e, &j);
    out->matrix.AddBlock(u, u, j.transpose() * c.information * j);
    out->gradient.segment<kPoseDim>(kPoseDim * u) += j.transpose() * (c.information * e);
  }
  // Observations: pose blocks, then each feature's Schur complement.
  out->features.resize(problem_.features.size());
  out->feature_damping.resize(problem_.features.size());
  std::vector<std::pair<int, Matrix63>> pose_feature;
  for (size_t f = 0; f < observations_of_feature_.size(); ++f) {
    FeatureBlocks& blocks = out->features[f];
    blocks.poses.clear();
    blocks.pose_feature.clear();
    if (observations_of_feature_[f].empty()) continue;
    Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    pose_feature.clear();
    for (int32_t k : observations_of_feature_[f]) {
      const Point3Observation& o = problem_.observations[k];
      Eigen::Vector3d e;
      Matrix36 jp;
      Eigen::Matrix3d jm;
      EvaluatePoint3Observation(poses[o.pose], features[f], o.z, &e, &jp, &jm);
      const Eigen::Matrix3d wjm = o.information * jm;
      c += jm.transpose() * wjm;
      g += jm.transpose() * (o.information * e);
      const int32_t u = unknown_[o.pose];
      if (u < 0) continue;
      out->matrix.AddBlock(u, u, jp.transpose() * o.information * jp);
      out->gradient.segment<kPoseDim>(kPoseDim * u) += jp.transpose() * (o.information * e);
      const Matrix63 hpm = jp.transpose() * wjm;
      auto it = std::find_if(pose_feature.begin(), pose_feature.end(),
                             [u](const auto& entry) { return entry.first == u; });
      if (it == pose_feature.end()) {
        pose_feature.emplace_back(u, hpm);
      } else {
        it->second += hpm;
      }
    }
    const Eigen::Vector3d damping = c.diagonal().cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
    out->feature_damping[f] = damping;
    blocks.feature_information = c;
    blocks.feature_information.diagonal() += lambda * damping;
    blocks.feature_gradient = g;
    for (const auto& [u, hpm] : pose_feature) {
      blocks.poses.push_back(u);
      blocks.pose_feature.push_back(hpm);
    }
  }
  out->hessian_diagonal = out->matrix.Diagonal();
  out->rhs = -out->gradient;
  for (size_t f = 0; f < out->features.size(); ++f) {
    FeatureBlocks& blocks = out->features[f];
    if (observations_of_feature_[f].empty()) continue;
    scratch->Clear();
    if (blocks.poses.empty()) {
      // Seen only from anchors: nothing to add to S, but it must still be
      // invertible for the recovery.
      Eigen::LLT<Eigen::MatrixXd> llt(blocks.feature_information);
      if (llt.info() != Eigen::Success) {
        *status = Status::Numerical("feature " + std::to_string(problem_.feature_ids[f]) +
                                    " has an information matrix that is not positive definite");
        return;
      }
      continue;
    }
    Status s = EliminateFeature(blocks, scratch);
    if (!s.ok()) {
      *status = Status::Numerical("feature " + std::to_string(problem_.feature_ids[f]) + ": " +
                                  s.ToString());
      return;
    }
    AccumulateContribution(*scratch, &out->matrix, &out->rhs);
  }
}

Status Solver3d::Run(SolverSummary* summary) {
  const Clock::time_point start = Clock::now();
  unknown_ = MakeLayout(problem_, &num_unknown_);
  summary->unknown_poses = num_unknown_;
  observations_of_feature_.assign(problem_.features.size(), {});
  for (size_t k = 0; k < problem_.observations.size(); ++k)
    observations_of_feature_[problem_.observations[k].feature].push_back(static_cast<int32_t>(k));
  summary->excluded.assign(problem_.features.size(), 0);
  for (size_t f = 0; f < problem_.features.size(); ++f) {
    if (observations_of_feature_[f].empty()) {
      summary->excluded[f] = 1;
      ++summary->unobserved_features;
    }
  }
  summary->observations_used = static_cast<int64_t>(problem_.observations.size());
  summary->eliminated_features = problem_.num_features() - summary->unobserved_features;

  // Pattern of S: pose-pose edges plus every pair of poses sharing a feature.
  std::vector<std::pair<int, int>> pairs;
  for (const RelativePose3Constraint& c : problem_.relative_poses) {
    const int32_t ui = unknown_[c.from], uj = unknown_[c.to];
    if (ui >= 0 && uj >= 0) pairs.emplace_back(ui, uj);
  }
  std::vector<int> seen;
  for (const std::vector<int32_t>& list : observations_of_feature_) {
    seen.clear();
    for (int32_t k : list) {
      const int32_t u = unknown_[problem_.observations[k].pose];
      if (u >= 0) seen.push_back(u);
    }
    std::sort(seen.begin(), seen.end());
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    for (size_t a = 0; a < seen.size(); ++a)
      for (size_t b = a + 1; b < seen.size(); ++b) pairs.emplace_back(seen[a], seen[b]);
  }
  Linearization system;
  system.matrix = BlockSparseMatrix::FromPattern(kPoseDim, num_unknown_, std::move(pairs));
  summary->reduced_nonzero_blocks = system.matrix.num_nonzero_blocks();
  type_ = options_.linear_solver;
  if (type_ == LinearSolverType::kAuto) {
    type_ = system.matrix.num_rows() <= options_.auto_cholmod_max_unknowns
                ? LinearSolverType::kCholmod
                : LinearSolverType::kPcg;
  }
  summary->linear_solver_used = type_;

  std::vector<Pose3>& poses = problem_.poses;
  std::vector<Point3>& features = problem_.features;
  double chi2 = Chi2Of3d(problem_, poses, features);
  summary->initial_chi2 = chi2;
  summary->final_chi2 = chi2;
  if (!std::isfinite(chi2)) {
    return Status::Numerical("initial chi2 is not finite (" + std::to_string(chi2) +
                             "); check the initial guess and information matrices");
  }
  double radius = options_.initial_trust_region_radius;
  double decrease_factor = 2.0;
  summary->termination = "max_iterations";
  ReducedContribution scratch;
  Eigen::VectorXd pose_step;
  std::vector<Pose3> candidate_poses;
  std::vector<Point3> candidate_features;

  for (int iteration = 1; iteration <= options_.max_iterations; ++iteration) {
    const Clock::time_point iteration_start = Clock::now();
    IterationSummary it;
    it.iteration = iteration;
    it.lambda = 1.0 / radius;

    Status linearize_status;
    Linearize(poses, features, it.lambda, &system, &scratch, &linearize_status);
    it.reduce_seconds = SecondsSince(iteration_start);
    const int rows = system.matrix.num_rows();
    it.gradient_max_norm = rows > 0 ? system.gradient.cwiseAbs().maxCoeff() : 0.0;
    if (linearize_status.ok() && it.gradient_max_norm <= options_.gradient_tolerance) {
      summary->termination = "gradient_tolerance";
      summary->converged = true;
      break;
    }
    const Eigen::VectorXd damping =
        system.hessian_diagonal.cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
    bool step_ok = linearize_status.ok();
    const Clock::time_point solve_start = Clock::now();
    if (step_ok) {
      system.matrix.AddToDiagonal(it.lambda * damping);
      Status s = SolveReduced(system.matrix, system.rhs, &pose_step, &it.linear_iterations);
      if (!s.ok()) GS_VLOG(1, "3-D linear solve failed (%s); raising damping", s.ToString().c_str());
      step_ok = s.ok();
    } else {
      GS_VLOG(1, "3-D reduce failed (%s); raising damping", linearize_status.ToString().c_str());
    }
    it.solve_seconds = SecondsSince(solve_start);
    const Clock::time_point recover_start = Clock::now();
    double candidate_chi2 = std::numeric_limits<double>::infinity();
    double model_decrease = 0.0;
    double step_squared = 0.0;
    double state_squared = 0.0;
    if (step_ok) {
      candidate_poses = poses;
      for (size_t p = 0; p < poses.size(); ++p) {
        const int32_t u = unknown_[p];
        if (u < 0) continue;
        candidate_poses[p] = RetractPose3(poses[p], pose_step.segment<kPoseDim>(kPoseDim * u));
        state_squared += LogSE3(poses[p]).squaredNorm();
      }
      model_decrease = -system.gradient.dot(pose_step) +
                       it.lambda * pose_step.dot(damping.cwiseProduct(pose_step));
      step_squared = pose_step.squaredNorm();
      candidate_features = features;
      for (size_t f = 0; f < features.size(); ++f) {
        if (summary->excluded[f]) continue;
        const FeatureBlocks& blocks = system.features[f];
        Eigen::VectorXd dm;
        if (blocks.poses.empty()) {
          dm = -blocks.feature_information.llt().solve(blocks.feature_gradient);
        } else {
          dm = RecoverFeature(blocks, pose_step);
        }
        candidate_features[f] = features[f] + dm;
        model_decrease += -blocks.feature_gradient.dot(dm) +
                          it.lambda * dm.dot(system.feature_damping[f].cwiseProduct(dm));
        step_squared += dm.squaredNorm();
        state_squared += features[f].squaredNorm();
      }
      candidate_chi2 = Chi2Of3d(problem_, candidate_poses, candidate_features);
      it.step_norm = std::sqrt(step_squared);
    }
    it.recover_seconds = SecondsSince(recover_start);
    it.candidate_chi2 = candidate_chi2;
    it.relative_decrease = model_decrease > 0.0 ? (chi2 - candidate_chi2) / model_decrease : -1.0;
    it.accepted = step_ok && std::isfinite(candidate_chi2) &&
                  it.relative_decrease > options_.min_relative_decrease;
    bool converged = false;
    if (it.accepted) {
      const double relative_change = (chi2 - candidate_chi2) / std::max(chi2, 1e-300);
      poses.swap(candidate_poses);
      features.swap(candidate_features);
      chi2 = candidate_chi2;
      const double factor = 1.0 - std::pow(2.0 * it.relative_decrease - 1.0, 3);
      radius = std::min(radius / std::max(1.0 / 3.0, factor), options_.max_trust_region_radius);
      decrease_factor = 2.0;
      if (relative_change < options_.function_tolerance) {
        summary->termination = "function_tolerance";
        converged = true;
      } else if (it.step_norm <= options_.parameter_tolerance *
                                     (std::sqrt(state_squared) + options_.parameter_tolerance)) {
        summary->termination = "parameter_tolerance";
        converged = true;
      }
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2.0;
    }
    it.chi2 = chi2;
    it.seconds = SecondsSince(iteration_start);
    summary->per_iteration.push_back(it);
    summary->iterations = iteration;
    summary->final_chi2 = chi2;
    GS_VLOG(1, "3-D iteration %d: chi2 %.9g candidate %.9g rho %.3g lambda %.3g |step| %.3g %s",
            iteration, chi2, candidate_chi2, it.relative_decrease, it.lambda, it.step_norm,
            it.accepted ? "accepted" : "rejected");
    if (options_.iteration_callback) options_.iteration_callback(it);
    if (options_.progress) options_.progress("optimize", iteration, options_.max_iterations);
    if (!converged && radius < options_.min_trust_region_radius) {
      summary->termination = "min_trust_region_radius";
      converged = true;
    }
    if (converged) {
      summary->converged = true;
      break;
    }
  }
  summary->seconds = SecondsSince(start);
  return Status::Ok();
}

}  // namespace

double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features) {
  double chi2 = 0.0;
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    Vector6d e;
    EvaluateRelativePose3(poses[c.from], poses[c.to], c.z, &e, nullptr, nullptr);
    chi2 += e.dot(c.information * e);
  }
  for (const Gps3Constraint& c : problem.gps) {
    Eigen::Vector3d e;
    EvaluateGps3(poses[c.pose], c.z, &e, nullptr);
    chi2 += e.dot(c.information * e);
  }
  for (const Point3Observation& o : problem.observations) {
    Eigen::Vector3d e;
    EvaluatePoint3Observation(poses[o.pose], features[o.feature], o.z, &e, nullptr, nullptr);
    chi2 += e.dot(o.information * e);
  }
  return chi2;
}

Status SolveGraphSlam3d(const SolverOptions& options, Problem3d* problem,
                        SolverSummary* summary) {
  GS_RETURN_IF_ERROR(options.Validate());
  *summary = SolverSummary();
  Solver3d solver(options, problem);
  return solver.Run(summary);
}

}  // namespace graphslam::core
