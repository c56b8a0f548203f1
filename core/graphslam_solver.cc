#include "core/graphslam_solver.h"

#include <string>

#include "core/internal/chunked_solve.h"

namespace graphslam::core {

const char* LinearSolverName(LinearSolverType type) {
  switch (type) {
    case LinearSolverType::kAuto: return "auto";
    case LinearSolverType::kPcg: return "pcg";
    case LinearSolverType::kCholmod: return "cholmod";
  }
  return "unknown";
}

StatusOr<LinearSolverType> ParseLinearSolverType(std::string_view name) {
  if (name == "auto") return LinearSolverType::kAuto;
  if (name == "pcg") return LinearSolverType::kPcg;
  if (name == "cholmod") return LinearSolverType::kCholmod;
  return Status::InvalidArgument("unknown linear solver '" + std::string(name) +
                                 "'; expected auto, pcg or cholmod");
}

const char* PreconditionerName(PreconditionerType type) {
  switch (type) {
    case PreconditionerType::kBlockJacobi: return "block-jacobi";
    case PreconditionerType::kIncompleteCholesky: return "incomplete-cholesky";
    case PreconditionerType::kSubgraph: return "subgraph";
  }
  return "unknown";
}

StatusOr<PreconditionerType> ParsePreconditionerType(std::string_view name) {
  if (name == "block-jacobi") return PreconditionerType::kBlockJacobi;
  if (name == "incomplete-cholesky") return PreconditionerType::kIncompleteCholesky;
  if (name == "subgraph") return PreconditionerType::kSubgraph;
  return Status::InvalidArgument("unknown preconditioner '" + std::string(name) +
                                 "'; expected block-jacobi, incomplete-cholesky or subgraph");
}

Status SolverOptions::Validate() const {
  if (max_iterations < 0)
    return Status::InvalidArgument("max_iterations must be >= 0, got " +
                                   std::to_string(max_iterations));
  if (!(function_tolerance >= 0) || !(gradient_tolerance >= 0) || !(parameter_tolerance >= 0))
    return Status::InvalidArgument("tolerances must be non-negative");
  if (!(model_tolerance >= 0.0) || !(model_tolerance < 1.0))
    return Status::InvalidArgument("model_tolerance must be in [0, 1), got " +
                                   std::to_string(model_tolerance));
  if (!(initial_trust_region_radius >= 0) ||
      !(max_trust_region_radius >= initial_trust_region_radius))
    return Status::InvalidArgument(
        "trust region radii must satisfy 0 <= initial <= max (0: by the linear solver)");
  if (pcg_max_iterations <= 0 || !(pcg_relative_tolerance > 0))
    return Status::InvalidArgument("PCG needs max_iterations > 0 and relative_tolerance > 0");
  if (max_eliminated_observations < 0)
    return Status::InvalidArgument("max_eliminated_observations must be >= 0");
  if (!(abandon_below_rho >= 0.0) || !(abandon_below_rho < 1.0))
    return Status::InvalidArgument("abandon_below_rho must be in [0, 1), got " +
                                   std::to_string(abandon_below_rho));
  if (anderson_depth < 0)
    return Status::InvalidArgument("anderson_depth must be >= 0, got " +
                                   std::to_string(anderson_depth));
  if (max_chunks_in_flight <= 0)
    return Status::InvalidArgument("max_chunks_in_flight must be > 0");
  return Status::Ok();
}

Status SolveGraphSlam(const SolverOptions& options, const ChunkSource& chunks,
                      Problem2d* problem, SolverSummary* summary) {
  return internal::SolveChunked<Space2d>(options, chunks, problem, summary, options.resume_from,
                                         options.checkpoint_callback);
}

}  // namespace graphslam::core
