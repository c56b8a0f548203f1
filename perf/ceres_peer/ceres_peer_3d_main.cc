// graphslam_ceres_peer_3d: solves a 3-D g2o graph (VERTEX_SE3:QUAT,
// EDGE_SE3:QUAT, VERTEX_TRACKXYZ, EDGE_SE3_TRACKXYZ, EDGE_SE3_XYZPRIOR) with
// Ceres Solver, as the converged peer of `graphslam solve` on 3-D inputs
// (docs/history/benchmarks-notebook-2026-11.md, "3-D pose graphs").
//
//   graphslam_ceres_peer_3d INPUT.g2o [--report R.json] [--max-iterations N]
//                           [--function-tolerance T] [--gradient-tolerance G]
//                           [--parameter-tolerance P] [--threads N] [-q]
//
// Pipeline: storage::ReadG2o3d -> core::InitializeProblem3d (the reader and
// the initial guess of `graphslam solve`) -> one ceres::Problem with the
// residuals of se3_cost_functors.h (written from g2o's definitions, not from
// core/) -> Levenberg-Marquardt with SPARSE_NORMAL_CHOLESKY (SuiteSparse).
// Gauge as ours: FIX poses constant, else pose 0 unless a position prior
// ties the map. chi2 = 2 x Ceres' cost = sum e^T Omega e.
//
// Exit codes: 0 converged, 1 usage, 2 bad input, 4 did not converge.
// THREAD SAFETY: a program. ALLOCATION: the problem and Ceres' factorization.
#include <ceres/ceres.h>
#include <ceres/version.h>
#include <glog/logging.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/initialization_3d.h"
#include "core/problem_3d.h"
#include "perf/ceres_peer/se3_cost_functors.h"
#include "storage/atomic_file.h"
#include "storage/env.h"
#include "storage/g2o_3d_reader.h"
#include "tools/exit_codes.h"

namespace graphslam::perf {
namespace {

struct Options {
  std::string input;
  std::string report;
  int max_iterations = 500;
  double function_tolerance = 1e-12;
  double gradient_tolerance = 1e-12;
  double parameter_tolerance = 1e-12;
  int threads = 1;
  bool quiet = false;
};

int Run(const Options& options) {
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam_ceres_peer_3d: %s\n", status.ToString().c_str());
    return tools::ExitCodeFor(status);
  };
  StatusOr<core::Problem3d> read = storage::ReadG2o3d(options.input);
  if (!read.ok()) return fail(read.status());
  core::Problem3d problem = std::move(read).value();
  if (Status status = core::InitializeProblem3d(&problem); !status.ok()) return fail(status);

  const int n = problem.num_poses();
  std::vector<double> t(3 * n), q(4 * n), m(3 * problem.features.size());
  for (int i = 0; i < n; ++i) {
    Eigen::Map<Eigen::Vector3d>{&t[3 * i]} = problem.poses[i].t;
    Eigen::Map<Eigen::Vector4d>{&q[4 * i]} = problem.poses[i].q.coeffs();  // x y z w
  }
  for (size_t f = 0; f < problem.features.size(); ++f)
    Eigen::Map<Eigen::Vector3d>{&m[3 * f]} = problem.features[f];

  ceres::Problem ceres_problem;
  for (const core::RelativePose3Constraint& c : problem.relative_poses) {
    auto* cost = new ceres::AutoDiffCostFunction<RelativePose3Cost, 6, 3, 4, 3, 4>(
        new RelativePose3Cost(c.z.t, c.z.q, c.information));
    ceres_problem.AddResidualBlock(cost, nullptr, &t[3 * c.from], &q[4 * c.from], &t[3 * c.to],
                                   &q[4 * c.to]);
  }
  for (const core::Point3Observation& o : problem.observations) {
    auto* cost = new ceres::AutoDiffCostFunction<PointInPoseCost, 3, 3, 4, 3>(
        new PointInPoseCost(o.z, o.information));
    ceres_problem.AddResidualBlock(cost, nullptr, &t[3 * o.pose], &q[4 * o.pose],
                                   &m[3 * o.feature]);
  }
  for (const core::Gps3Constraint& g : problem.gps) {
    auto* cost = new ceres::AutoDiffCostFunction<PositionPrior3Cost, 3, 3>(
        new PositionPrior3Cost(g.z, g.information));
    ceres_problem.AddResidualBlock(cost, nullptr, &t[3 * g.pose]);
  }
  bool any_fixed = false;
  for (int i = 0; i < n; ++i) {
    if (!ceres_problem.HasParameterBlock(&q[4 * i])) continue;
    ceres_problem.SetManifold(&q[4 * i], new ceres::EigenQuaternionManifold());
    if (problem.pose_fixed[i]) {
      any_fixed = true;
      ceres_problem.SetParameterBlockConstant(&t[3 * i]);
      ceres_problem.SetParameterBlockConstant(&q[4 * i]);
    }
  }
  if (!any_fixed && problem.gps.empty() && n > 0 && ceres_problem.HasParameterBlock(&t[0])) {
    ceres_problem.SetParameterBlockConstant(&t[0]);
    if (ceres_problem.HasParameterBlock(&q[0])) ceres_problem.SetParameterBlockConstant(&q[0]);
  }

  ceres::Solver::Options solver_options;
  solver_options.minimizer_type = ceres::TRUST_REGION;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.gradient_tolerance = options.gradient_tolerance;
  solver_options.parameter_tolerance = options.parameter_tolerance;
  solver_options.num_threads = options.threads;
  solver_options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &ceres_problem, &summary);
  if (summary.termination_type == ceres::FAILURE)
    return fail(Status::Numerical(options.input + ": Ceres failed: " + summary.message));
  const bool converged = summary.termination_type == ceres::CONVERGENCE;
  const int iterations = static_cast<int>(summary.iterations.size()) - 1;
  if (!options.report.empty()) {
    nlohmann::json report;
    report["peer"] = std::string("ceres ") + CERES_VERSION_STRING;
    report["input"] = options.input;
    report["dimension"] = 3;
    report["initial_chi2"] = 2.0 * summary.initial_cost;
    report["final_chi2"] = 2.0 * summary.final_cost;
    report["iterations"] = iterations;
    report["successful_steps"] = summary.num_successful_steps;
    report["converged"] = converged;
    report["termination"] = summary.message;
    report["seconds"] = summary.total_time_in_seconds;
    if (Status status = storage::WriteStringAtomically(storage::Env::Default(), options.report,
                                                       report.dump(2) + "\n");
        !status.ok())
      return fail(status);
  }
  if (!options.quiet) {
    std::printf("ceres %s on %s: chi2 %.9g -> %.9g, %d iterations (%d successful), %s, %.2f s\n",
                CERES_VERSION_STRING, options.input.c_str(), 2.0 * summary.initial_cost,
                2.0 * summary.final_cost, iterations, summary.num_successful_steps,
                summary.message.c_str(), summary.total_time_in_seconds);
  }
  return converged ? tools::kExitOk : tools::kExitNotConverged;
}

}  // namespace
}  // namespace graphslam::perf

int main(int argc, char** argv) {
  google::InitGoogleLogging(argv[0]);
  graphslam::perf::Options options;
  CLI::App app{"Solve a 3-D g2o graph with Ceres Solver (peer of graphslam solve)"};
  app.add_option("input", options.input, "3-D g2o file")->required();
  app.add_option("--report", options.report, "JSON report");
  app.add_option("--max-iterations", options.max_iterations)->capture_default_str();
  app.add_option("--function-tolerance", options.function_tolerance)->capture_default_str();
  app.add_option("--gradient-tolerance", options.gradient_tolerance)->capture_default_str();
  app.add_option("--parameter-tolerance", options.parameter_tolerance)->capture_default_str();
  app.add_option("--threads", options.threads)->capture_default_str();
  app.add_flag("-q,--quiet", options.quiet);
  CLI11_PARSE(app, argc, argv);
  return graphslam::perf::Run(options);
}
