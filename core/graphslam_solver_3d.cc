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
#include "core/levenberg_marquardt.h"
#include "core/logging.h"
#include "core/point3_observation_model.h"
#include "core/preconditioned_conjugate_gradient.h"
#include "core/relative_pose3_model.h"
#include "core/schur_eliminator.h"

namespace graphslam::core {
namespace {

constexpr int kPoseDim = 6;
constexpr int kPointDim = 3;
using Clock = SolverClock;
using Matrix36 = Eigen::Matrix<double, 3, 6>;
using Matrix63 = Eigen::Matrix<double, 6, 3>;

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

// The 3-D problem space of RunLevenbergMarquardt (core/levenberg_marquardt.h):
// SE(3) poses (6 x 6 blocks) and 3-D points (3 x 3 blocks), the whole
// problem in memory.
class Space3d {
 public:
  using Checkpoint = SolverCheckpoint3d;
  static constexpr const char* kName = "3-D ";

  Space3d(const SolverOptions& options, Problem3d* problem)
      : options_(options), problem_(*problem) {}

  // Layout, feature partition and the pattern of S; takes over `resume`'s
  // state when given.
  Status Setup(const SolverCheckpoint3d* resume, SolverSummary* summary);

  Status Linearize(double lambda, IterationSummary* it, bool* usable) {
    Status status;
    LinearizeAt(problem_.poses, problem_.features, lambda, &system_, &scratch_, &status);
    const int rows = system_.matrix.num_rows();
    it->gradient_max_norm = rows > 0 ? system_.gradient.cwiseAbs().maxCoeff() : 0.0;
    *usable = status.ok();
    if (!status.ok()) GS_VLOG(1, "3-D reduce failed (%s); raising damping", status.ToString().c_str());
    return Status::Ok();
  }

  // Two linearizations per iteration (no speculation): speculative_lambda is unused.
  Status TryStep(double lambda, double speculative_lambda, bool usable, IterationSummary* it,
                 TrialStep* trial);
  void StepResult(bool /*accepted*/) {}
  void Accept() {
    problem_.poses.swap(candidate_poses_);
    problem_.features.swap(candidate_features_);
  }
  void FillState(Checkpoint* checkpoint) const {
    checkpoint->poses = problem_.poses;
    checkpoint->features = problem_.features;
    checkpoint->excluded = excluded_;
    checkpoint->kept.assign(problem_.features.size(), 0);  // every feature is eliminated
  }

 private:
  void LinearizeAt(const std::vector<Pose3>& poses, const std::vector<Point3>& features,
                   double lambda, Linearization* out, ReducedContribution* scratch,
                   Status* status);
  Status SolveReduced(const BlockSparseMatrix& matrix, const Eigen::VectorXd& rhs,
                      Eigen::VectorXd* x, int* iterations);

  const SolverOptions& options_;
  Problem3d& problem_;
  std::vector<int32_t> unknown_;
  int32_t num_unknown_ = 0;
  std::vector<std::vector<int32_t>> observations_of_feature_;
  std::vector<uint8_t> excluded_;
  LinearSolverType type_ = LinearSolverType::kCholmod;
  CholmodSolver cholmod_;
  BlockJacobiPreconditioner block_jacobi_;
  IncompleteCholeskyPreconditioner incomplete_cholesky_;
  Linearization system_;
  ReducedContribution scratch_;
  Eigen::VectorXd pose_step_;
  std::vector<Pose3> candidate_poses_;
  std::vector<Point3> candidate_features_;
};

Status Space3d::SolveReduced(const BlockSparseMatrix& matrix, const Eigen::VectorXd& rhs,
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

void Space3d::LinearizeAt(const std::vector<Pose3>& poses, const std::vector<Point3>& features,
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
    // IRLS on the pose constraints too (SolverOptions::pose_kernels); the
    // weight is exactly 1 without a kernel.
    const Matrix6d information =
        options_.pose_kernels.relative_pose.Weight(e.dot(c.information * e)) * c.information;
    const Matrix6d wji = information * ji, wjj = information * jj;
    if (ui >= 0) {
      out->matrix.AddBlock(ui, ui, ji.transpose() * wji);
      out->gradient.segment<kPoseDim>(kPoseDim * ui) += ji.transpose() * (information * e);
    }
    if (uj >= 0) {
      out->matrix.AddBlock(uj, uj, jj.transpose() * wjj);
      out->gradient.segment<kPoseDim>(kPoseDim * uj) += jj.transpose() * (information * e);
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
    const Eigen::Matrix3d information =
        options_.pose_kernels.gps.Weight(e.dot(c.information * e)) * c.information;
    out->matrix.AddBlock(u, u, j.transpose() * information * j);
    out->gradient.segment<kPoseDim>(kPoseDim * u) += j.transpose() * (information * e);
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
      // IRLS (core/robust_kernel.h): the information scaled by rho'(s); the
      // weight is exactly 1 without a kernel.
      const Eigen::Matrix3d information =
          options_.observation_kernel.Weight(e.dot(o.information * e)) * o.information;
      const Eigen::Matrix3d wjm = information * jm;
      c += jm.transpose() * wjm;
      g += jm.transpose() * (information * e);
      const int32_t u = unknown_[o.pose];
      if (u < 0) continue;
      out->matrix.AddBlock(u, u, jp.transpose() * information * jp);
      out->gradient.segment<kPoseDim>(kPoseDim * u) += jp.transpose() * (information * e);
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

Status Space3d::Setup(const SolverCheckpoint3d* resume, SolverSummary* summary) {
  unknown_ = MakeLayout(problem_, &num_unknown_);
  summary->unknown_poses = num_unknown_;
  observations_of_feature_.assign(problem_.features.size(), {});
  for (size_t k = 0; k < problem_.observations.size(); ++k)
    observations_of_feature_[problem_.observations[k].feature].push_back(static_cast<int32_t>(k));
  excluded_.assign(problem_.features.size(), 0);
  for (size_t f = 0; f < problem_.features.size(); ++f) {
    if (observations_of_feature_[f].empty()) {
      excluded_[f] = 1;
      ++summary->unobserved_features;
    }
  }
  if (resume != nullptr) {
    if (resume->poses.size() != problem_.poses.size() ||
        resume->features.size() != problem_.features.size() ||
        resume->excluded != excluded_) {
      return Status::InvalidArgument(
          "checkpoint does not match the problem: " + std::to_string(resume->poses.size()) +
          " poses and " + std::to_string(resume->features.size()) +
          " features (or another set of unobserved features), expected " +
          std::to_string(problem_.poses.size()) + " and " +
          std::to_string(problem_.features.size()));
    }
    problem_.poses = resume->poses;
    problem_.features = resume->features;
  }
  summary->excluded = excluded_;
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
  system_.matrix = BlockSparseMatrix::FromPattern(kPoseDim, num_unknown_, std::move(pairs));
  summary->reduced_nonzero_blocks = system_.matrix.num_nonzero_blocks();
  type_ = options_.linear_solver;
  if (type_ == LinearSolverType::kAuto) {
    type_ = system_.matrix.num_rows() <= options_.auto_cholmod_max_unknowns
                ? LinearSolverType::kCholmod
                : LinearSolverType::kPcg;
  }
  summary->linear_solver_used = type_;
  return Status::Ok();
}

Status Space3d::TryStep(double lambda, double /*speculative_lambda*/, bool usable,
                        IterationSummary* it, TrialStep* trial) {
  const std::vector<Pose3>& poses = problem_.poses;
  const std::vector<Point3>& features = problem_.features;
  const Eigen::VectorXd damping =
      system_.hessian_diagonal.cwiseMax(kMinDiagonal).cwiseMin(kMaxDiagonal);
  trial->ok = usable;
  const Clock::time_point solve_start = Clock::now();
  if (trial->ok) {
    system_.matrix.AddToDiagonal(lambda * damping);
    Status s = SolveReduced(system_.matrix, system_.rhs, &pose_step_, &it->linear_iterations);
    if (!s.ok()) GS_VLOG(1, "3-D linear solve failed (%s); raising damping", s.ToString().c_str());
    trial->ok = s.ok();
  }
  it->solve_seconds = SecondsSince(solve_start);
  const Clock::time_point recover_start = Clock::now();
  if (trial->ok) {
    double step_squared = 0.0;
    double state_squared = 0.0;
    candidate_poses_ = poses;
    for (size_t p = 0; p < poses.size(); ++p) {
      const int32_t u = unknown_[p];
      if (u < 0) continue;
      candidate_poses_[p] = RetractPose3(poses[p], pose_step_.segment<kPoseDim>(kPoseDim * u));
      state_squared += LogSE3(poses[p]).squaredNorm();
    }
    double model_decrease = -system_.gradient.dot(pose_step_) +
                            lambda * pose_step_.dot(damping.cwiseProduct(pose_step_));
    step_squared = pose_step_.squaredNorm();
    candidate_features_ = features;
    for (size_t f = 0; f < features.size(); ++f) {
      if (excluded_[f]) continue;
      const FeatureBlocks& blocks = system_.features[f];
      Eigen::VectorXd dm;
      if (blocks.poses.empty()) {
        dm = -blocks.feature_information.llt().solve(blocks.feature_gradient);
      } else {
        dm = RecoverFeature(blocks, pose_step_);
      }
      candidate_features_[f] = features[f] + dm;
      model_decrease += -blocks.feature_gradient.dot(dm) +
                        lambda * dm.dot(system_.feature_damping[f].cwiseProduct(dm));
      step_squared += dm.squaredNorm();
      state_squared += features[f].squaredNorm();
    }
    trial->candidate_chi2 =
        Chi2Of3d(problem_, candidate_poses_, candidate_features_, options_.observation_kernel,
                 options_.pose_kernels);
    trial->model_decrease = model_decrease;
    trial->state_norm_squared = state_squared;
    it->step_norm = std::sqrt(step_squared);
  }
  it->recover_seconds = SecondsSince(recover_start);
  return Status::Ok();
}

}  // namespace

double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features) {
  return Chi2Of3d(problem, poses, features, RobustKernel());
}

double Chi2Of3d(const Problem3d& problem, const std::vector<Pose3>& poses,
                const std::vector<Point3>& features, const RobustKernel& kernel,
                const PoseFactorKernels& pose_kernels) {
  double chi2 = 0.0;
  for (const RelativePose3Constraint& c : problem.relative_poses) {
    Vector6d e;
    EvaluateRelativePose3(poses[c.from], poses[c.to], c.z, &e, nullptr, nullptr);
    chi2 += pose_kernels.relative_pose.Cost(e.dot(c.information * e));
  }
  for (const Gps3Constraint& c : problem.gps) {
    Eigen::Vector3d e;
    EvaluateGps3(poses[c.pose], c.z, &e, nullptr);
    chi2 += pose_kernels.gps.Cost(e.dot(c.information * e));
  }
  for (const Point3Observation& o : problem.observations) {
    Eigen::Vector3d e;
    EvaluatePoint3Observation(poses[o.pose], features[o.feature], o.z, &e, nullptr, nullptr);
    chi2 += kernel.Cost(e.dot(o.information * e));
  }
  return chi2;
}

Status SolveGraphSlam3d(const SolverOptions& options, Problem3d* problem,
                        SolverSummary* summary, const Checkpointing3d& checkpointing) {
  GS_RETURN_IF_ERROR(options.Validate());
  const Clock::time_point start = Clock::now();
  *summary = SolverSummary();
  Space3d space(options, problem);
  GS_RETURN_IF_ERROR(space.Setup(checkpointing.resume_from, summary));
  const double chi2 =
      Chi2Of3d(*problem, problem->poses, problem->features, options.observation_kernel,
               options.pose_kernels);
  return RunLevenbergMarquardt(options, chi2, checkpointing.resume_from, checkpointing.callback,
                               start, &space, summary);
}

}  // namespace graphslam::core
