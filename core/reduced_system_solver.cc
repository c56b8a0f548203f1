#include "core/reduced_system_solver.h"

#include <algorithm>
#include <cmath>
#include <fmt/format.h>

#include <memory>
#include <utility>

#include "core/check.h"
#include "core/logging.h"
#include "core/preconditioned_conjugate_gradient.h"

namespace graphslam::core {
namespace {

// Eisenstat-Walker choice 2.
constexpr double kForcingGamma = 0.9;
constexpr double kForcingAlpha = 2.0;

}  // namespace

Status ReducedSystemSolverOptions::Validate() const {
  if (pcg_max_iterations <= 0 || !(pcg_relative_tolerance > 0) ||
      !std::isfinite(pcg_relative_tolerance)) {
    return Status::InvalidArgument(fmt::format(
        "reduced system solver: PCG needs max_iterations > 0 and a positive finite tolerance, "
        "got {} and {:g}",
        pcg_max_iterations, pcg_relative_tolerance));
  }
  if (!(eta_max >= pcg_relative_tolerance) || !(eta_max < 1.0)) {
    return Status::InvalidArgument(fmt::format(
        "reduced system solver: eta_max must be in [pcg_relative_tolerance, 1), got {:g}",
        eta_max));
  }
  if (!(truncation >= 0.0) || !(truncation < 1.0)) {
    return Status::InvalidArgument(fmt::format(
        "reduced system solver: truncation must be in [0, 1), got {:g}", truncation));
  }
  if (deflation_poses < 0 || deflation_poses == 1) {
    return Status::InvalidArgument(fmt::format(
        "reduced system solver: deflation_poses must be 0 (off) or >= 2, got {}",
        deflation_poses));
  }
  if (max_factor_bytes < 0 || max_analysis_unknowns < 0) {
    return Status::InvalidArgument("reduced system solver: budgets must be >= 0");
  }
  return Status::Ok();
}

void ChooseFromAnalysis(double nonzeros, double n, double b,
                        const ReducedSystemSolverOptions& options, SolverChoice* choice) {
  const double crossover = options.eliminated_features ? kLandmarkCrossover : kPoseGraphCrossover;
  choice->pcg_cost = crossover * (2.0 * nonzeros + 4.0 * n * b);
  const double factor_bytes = 8.0 * choice->factor_nonzeros;
  const double cholmod_cost = choice->factor_flops + 4.0 * choice->factor_nonzeros;
  choice->type = factor_bytes <= static_cast<double>(options.max_factor_bytes) &&
                         cholmod_cost <= choice->pcg_cost
                     ? LinearSolverType::kCholmod
                     : LinearSolverType::kPcg;
}

StatusOr<SolverChoice> ChooseLinearSolver(const BlockSparseMatrix& s,
                                          const ReducedSystemSolverOptions& options) {
  SolverChoice choice;
  if (options.type == LinearSolverType::kCholmod && options.cholmod_factor_check &&
      s.num_rows() > 0) {
    // The analysis CholmodSolver would run first anyway: its fill is the
    // factor's size before a byte of it is allocated.
    choice.type = LinearSolverType::kCholmod;
    GS_ASSIGN_OR_RETURN(choice.ordering, AnalyzeCholmodOrdering(s));
    choice.factor_nonzeros = choice.ordering->factor_nonzeros;
    choice.factor_flops = choice.ordering->factor_flops;
    choice.analyzed = true;
    GS_RETURN_IF_ERROR(options.cholmod_factor_check(8.0 * choice.factor_nonzeros));
    return choice;
  }
  if (options.type != LinearSolverType::kAuto) {
    choice.type = options.type;
    return choice;
  }
  const double n = s.num_rows();
  const double b = s.block_size();
  const double nnz = static_cast<double>(s.num_nonzero_blocks()) * b * b;
  if (s.num_rows() == 0) {
    choice.type = LinearSolverType::kCholmod;
    return choice;
  }
  if (s.num_rows() > options.max_analysis_unknowns) {
    choice.type = LinearSolverType::kPcg;
    return choice;
  }
  // CHOLMOD's ordering and symbolic analysis of the pattern: the ordering
  // CholmodSolver will use (handed over, not repeated), and its exact fill
  // and flop count.
  StatusOr<std::shared_ptr<const CholmodOrdering>> ordering = AnalyzeCholmodOrdering(s);
  GS_RETURN_IF_ERROR(ordering.status());
  choice.ordering = std::move(ordering).value();
  choice.factor_nonzeros = choice.ordering->factor_nonzeros;
  choice.factor_flops = choice.ordering->factor_flops;
  choice.analyzed = true;
  ChooseFromAnalysis(nnz, n, b, options, &choice);
  return choice;
}

ReducedSystemSolver::ReducedSystemSolver(LinearSolverType type,
                                         const ReducedSystemSolverOptions& options)
    : type_(type), options_(options), eta_(options.eta_max) {
  GS_CHECK(type != LinearSolverType::kAuto);
  GS_CHECK(options.Validate().ok());
  if (!options_.forcing_sequence) eta_ = options_.pcg_relative_tolerance;
}

void ReducedSystemSolver::UseOrdering(std::shared_ptr<const CholmodOrdering> ordering) {
  cholmod_.UseOrdering(std::move(ordering));
}

void ReducedSystemSolver::StepResult(bool accepted) {
  if (!accepted || !options_.forcing_sequence) return;
  // The next linearization is new: eta follows the gradient's progress, read
  // at the next Solve. last_rhs_norm_ is the norm this step was solved for.
  previous_rhs_norm_ = last_rhs_norm_;
  have_previous_ = true;
}

void ReducedSystemSolver::SaveState(PcgSolverState* state) const {
  *state = PcgSolverState();
  if (type_ != LinearSolverType::kPcg) return;
  state->present = true;
  state->eta = eta_;
  state->previous_rhs_norm = previous_rhs_norm_;
  state->last_rhs_norm = last_rhs_norm_;
  state->have_previous = have_previous_;
  state->previous_x.assign(previous_x_.data(), previous_x_.data() + previous_x_.size());
  if (options_.preconditioner == PreconditionerType::kSubgraph) {
    state->forest_order = subgraph_.forest_order();
    state->forest_parent = subgraph_.forest_parent();
  }
}

Status ReducedSystemSolver::RestoreState(const PcgSolverState& state,
                                         const BlockSparseMatrix& pattern) {
  if (!state.present || type_ != LinearSolverType::kPcg) return Status::Ok();
  if (!std::isfinite(state.eta) || !(state.eta > 0.0) || !std::isfinite(state.previous_rhs_norm) ||
      !std::isfinite(state.last_rhs_norm)) {
    return Status::InvalidArgument(fmt::format(
        "PCG state: eta {:g}, previous_rhs_norm {:g} and last_rhs_norm {:g} must be finite "
        "(eta > 0)",
        state.eta, state.previous_rhs_norm, state.last_rhs_norm));
  }
  const size_t n = static_cast<size_t>(pattern.num_rows());
  if (!state.previous_x.empty() && state.previous_x.size() != n) {
    return Status::InvalidArgument(fmt::format(
        "PCG state: previous_x has {} entries, the reduced system {} unknowns",
        state.previous_x.size(), n));
  }
  for (double v : state.previous_x) {
    if (!std::isfinite(v)) return Status::InvalidArgument("PCG state: previous_x is not finite");
  }
  // A forest is ignored by another preconditioner (resumed with a different
  // --preconditioner: a different solve from here on, as with --solver).
  if (options_.preconditioner == PreconditionerType::kSubgraph &&
      (!state.forest_order.empty() || !state.forest_parent.empty())) {
    GS_RETURN_IF_ERROR(subgraph_.SetForest(pattern, state.forest_order, state.forest_parent));
  }
  eta_ = state.eta;
  previous_rhs_norm_ = state.previous_rhs_norm;
  last_rhs_norm_ = state.last_rhs_norm;
  have_previous_ = state.have_previous;
  previous_x_ = Eigen::Map<const Eigen::VectorXd>(
      state.previous_x.data(), static_cast<Eigen::Index>(state.previous_x.size()));
  return Status::Ok();
}

const LinearOperator* ReducedSystemSolver::UpdatePreconditioner(const BlockSparseMatrix& s,
                                                                Status* status) {
  switch (options_.preconditioner) {
    case PreconditionerType::kIncompleteCholesky:
      *status = incomplete_cholesky_.Update(s);
      return &incomplete_cholesky_;
    case PreconditionerType::kSubgraph:
      *status = subgraph_.Update(s);
      return &subgraph_;
    case PreconditionerType::kBlockJacobi:
      break;
  }
  *status = block_jacobi_.Update(s);
  return &block_jacobi_;
}

Status ReducedSystemSolver::Solve(const BlockSparseMatrix& s, const Eigen::VectorXd& rhs,
                                  Eigen::VectorXd* x, int* iterations, double chi2) {
  const int n = static_cast<int>(rhs.size());
  if (n == 0) {
    x->resize(0);
    *iterations = 0;
    return Status::Ok();
  }
  if (type_ == LinearSolverType::kCholmod) {
    GS_RETURN_IF_ERROR(cholmod_.Factorize(s));
    GS_RETURN_IF_ERROR(cholmod_.Solve(rhs, x));
    *iterations = 1;
    return Status::Ok();
  }

  // Forcing term for this linearization.
  const double rhs_norm = rhs.norm();
  if (options_.forcing_sequence && have_previous_ && previous_rhs_norm_ > 0.0) {
    const double previous_eta = eta_;
    double eta = kForcingGamma * std::pow(rhs_norm / previous_rhs_norm_, kForcingAlpha);
    const double safeguard = kForcingGamma * std::pow(previous_eta, kForcingAlpha);
    if (safeguard > 0.1) eta = std::max(eta, safeguard);
    eta_ = std::clamp(eta, options_.pcg_relative_tolerance, options_.eta_max);
    have_previous_ = false;  // one update per accepted step
  }
  last_rhs_norm_ = rhs_norm;

  Status status;
  const LinearOperator* preconditioner = UpdatePreconditioner(s, &status);
  GS_RETURN_IF_ERROR(status);
  if (options_.deflation_poses > 0) {
    if (deflation_ == nullptr) {
      deflation_ = std::make_unique<TrajectoryDeflation>(
          preconditioner, options_.deflation_poses,
          TrajectoryDeflation::DefaultLinearComponents(s.block_size()));
    }
    GS_RETURN_IF_ERROR(deflation_->Update(s));
    preconditioner = deflation_.get();
  }

  // Warm start: the previous solution scaled to the model's minimum along it.
  product_.resize(n);
  auto scale_to_model_minimum = [&](Eigen::VectorXd* v) {
    product_.setZero();
    s.RightMultiplyAndAccumulate(v->data(), product_.data());
    const double curvature = v->dot(product_);
    const double alpha = curvature > 0.0 ? rhs.dot(*v) / curvature : 0.0;
    if (alpha > 0.0 && std::isfinite(alpha)) {
      *v *= alpha;
    } else {
      v->setZero();
    }
  };
  if (options_.warm_start && previous_x_.size() == n && previous_x_.allFinite()) {
    *x = previous_x_;
    scale_to_model_minimum(x);
  } else {
    x->setZero(n);
  }

  // Deflated CG starts with a residual orthogonal to the coarse space.
  if (deflation_ != nullptr) GS_RETURN_IF_ERROR(deflation_->CoarseCorrect(s, rhs, x));

  PcgOptions pcg;
  pcg.max_iterations = options_.pcg_max_iterations;
  pcg.relative_tolerance = options_.forcing_sequence ? eta_ : options_.pcg_relative_tolerance;
  if (chi2 > 0.0 && std::isfinite(chi2)) pcg.energy_tolerance = options_.truncation * chi2;
  const PcgSummary summary = SolvePcg(s, *preconditioner, rhs, pcg, x);
  *iterations = summary.iterations;
  GS_VLOG(1, "PCG: %d iterations, relative residual %.3g (forcing term %.3g), %s",
          summary.iterations, summary.relative_residual, pcg.relative_tolerance,
          summary.converged   ? "converged"
          : summary.truncated ? "truncated by the chi2 estimate"
                              : "stopped (iteration cap or breakdown)");
  if (!x->allFinite()) return Status::Numerical("PCG produced a non-finite step");
  // rhs^T dx = dx^T S dx for the LM model decrease (item 4 of the header).
  if (options_.warm_start || options_.forcing_sequence) scale_to_model_minimum(x);
  previous_x_ = *x;
  return Status::Ok();
}

}  // namespace graphslam::core
