// graphslam_ceres_peer: solves a 2-D g2o graph with Ceres Solver (Agarwal,
// Mierle et al., http://ceres-solver.org) so that `graphslam solve` can be
// compared against a well-known peer on identical data (docs/peers.md).
//
//   graphslam_ceres_peer INPUT.g2o
//                        --linear-solver sparse_schur|iterative_schur|sparse_normal_cholesky
//                        --report REPORT.json [--max-iterations N] [--threads N]
//                        [--function-tolerance T] [--eta E] [--max-linear-iterations N]
//                        [--iteration-log FILE] [-q]
//
// Pipeline: storage::ReadG2o -> core::InitializeProblem (the same reader and
// the same initial guess as `graphslam solve --initialization odometry`) ->
// one ceres::Problem with the residuals of g2o_cost_functors.h -> Levenberg-
// Marquardt -> a JSON report with the keys of `graphslam solve --report`
// (tools/solve_command.cc BuildReport), plus "peer": "ceres <version>".
//
// Gauge: poses marked FIX are constant; if none is, pose 0 is constant.
// Schur ordering: landmarks in elimination group 0, poses in group 1. A
// pose-only graph has no landmarks: Ceres then picks its own elimination set
// (an independent set of poses) for the Schur solvers; if that fails the
// harness falls back to SPARSE_NORMAL_CHOLESKY (for sparse_schur) or
// CGNR + JACOBI (for iterative_schur) and says so in the report ("fallback").
//
// --iteration-log FILE: one JSON object per line and per Levenberg-Marquardt
// iteration (the per_iteration entry of the report plus "cpu_seconds", the
// process' user + system seconds so far), appended and flushed as each
// iteration ends, so a run stopped by a timeout still gives its time per
// iteration (perf/solver_comparison.py reads it).
//
// Exit codes as the graphslam tool (tools/exit_codes.h): 0 converged, 1 usage,
// 2 bad input, 3 I/O error, 4 did not converge.
//
// THREAD SAFETY: a program. ALLOCATION: the problem, Ceres' Jacobian and its
// factorization; peak RSS is reported.
#include <ceres/ceres.h>
#include <ceres/version.h>
#include <glog/logging.h>
#include <tbb/info.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/gps_model.h"
#include "core/initialization.h"
#include "core/point_observation_model.h"
#include "core/problem.h"
#include "core/relative_pose_model.h"
#include "core/status.h"
#include "perf/ceres_peer/g2o_cost_functors.h"
#include "storage/atomic_file.h"
#include "storage/env.h"
#include "storage/g2o_reader.h"
#include "tools/exit_codes.h"
#include "tools/resource_usage.h"

namespace graphslam::perf {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

struct PeerOptions {
  std::string input;
  // sparse_schur, iterative_schur, sparse_normal_cholesky
  std::string linear_solver = "sparse_schur";
  std::string report;
  int max_iterations = 200;
  double function_tolerance = 1e-6;
  int threads = 0;  // 0: all cores
  // Ceres' inexact-Newton forcing for ITERATIVE_SCHUR: CG stops when the
  // residual falls below eta times its start (Ceres' default 0.1).
  double eta = 1e-1;
  int max_linear_solver_iterations = 500;  // Ceres' default
  std::string iteration_log;               // --iteration-log FILE ("" = none)
  bool quiet = false;

  Status Validate() const {
    if (input.empty()) return Status::InvalidArgument("no INPUT given");
    if (linear_solver != "sparse_schur" && linear_solver != "iterative_schur" &&
        linear_solver != "sparse_normal_cholesky")
      return Status::InvalidArgument(
          "--linear-solver must be sparse_schur, iterative_schur or sparse_normal_cholesky, "
          "got '" + linear_solver + "'");
    if (max_iterations < 0)
      return Status::InvalidArgument("--max-iterations must be >= 0, got " +
                                     std::to_string(max_iterations));
    if (threads < 0)
      return Status::InvalidArgument("--threads must be >= 0, got " + std::to_string(threads));
    if (!(function_tolerance >= 0))
      return Status::InvalidArgument("--function-tolerance must be >= 0");
    if (!(eta > 0 && eta < 1))
      return Status::InvalidArgument("--eta must be in (0, 1), got " + std::to_string(eta));
    if (max_linear_solver_iterations <= 0)
      return Status::InvalidArgument("--max-linear-iterations must be > 0, got " +
                                     std::to_string(max_linear_solver_iterations));
    return Status::Ok();
  }
};

// chi2 = sum e^T Omega e with graphslam's own models (core/*_model.h), used to
// check that the Ceres residuals follow the same conventions.
double GraphSlamChi2(const core::Problem2d& problem) {
  double chi2 = 0.0;
  for (const core::RelativePoseConstraint& c : problem.relative_poses) {
    Eigen::Vector3d e;
    core::EvaluateRelativePose(problem.poses[c.from], problem.poses[c.to], c.z, &e, nullptr,
                               nullptr);
    chi2 += e.dot(c.information * e);
  }
  for (const core::Observation& o : problem.observations) {
    Eigen::Vector2d e;
    core::EvaluatePointObservation(problem.poses[o.pose], problem.features[o.feature], o.z, &e,
                                   nullptr, nullptr);
    chi2 += e.dot(o.information * e);
  }
  for (const core::GpsConstraint& g : problem.gps) {
    Eigen::Vector2d e;
    core::EvaluateGps(problem.poses[g.pose], g.z, &e, nullptr);
    chi2 += e.dot(g.information * e);
  }
  return chi2;
}

// Ceres' unknowns, laid out contiguously: 3 doubles per pose, 2 per landmark.
struct CeresState {
  std::vector<double> poses;
  std::vector<double> landmarks;
  double* pose(int32_t i) { return poses.data() + 3 * static_cast<size_t>(i); }
  double* landmark(int32_t j) { return landmarks.data() + 2 * static_cast<size_t>(j); }
};

// Rejects what the g2o residuals above cannot express (velocity motions and
// range-bearing observations come from other readers, never from ReadG2o).
Status CheckSupported(const core::Problem2d& problem) {
  if (!problem.motions.empty())
    return Status::NotSupported(problem.source + ": " + std::to_string(problem.motions.size()) +
                                " velocity motion constraints; the Ceres peer supports EDGE_SE2, "
                                "EDGE_SE2_XY and EDGE_PRIOR_SE2_XY only");
  for (const core::Observation& o : problem.observations) {
    if (o.kind != core::ObservationKind::kPointXY)
      return Status::NotSupported(problem.source + ":" + std::to_string(o.line) +
                                  ": " + core::ObservationKindName(o.kind) +
                                  " observation; expected EDGE_SE2_XY");
  }
  return Status::Ok();
}

// Fills `ceres_problem` with one residual block per constraint. Returns the
// number of landmarks that appear in at least one residual.
int32_t BuildCeresProblem(const core::Problem2d& problem, CeresState* state,
                          ceres::Problem* ceres_problem, ceres::ParameterBlockOrdering* ordering) {
  state->poses.resize(3 * problem.poses.size());
  state->landmarks.resize(2 * problem.features.size());
  for (int32_t i = 0; i < problem.num_poses(); ++i)
    for (int k = 0; k < 3; ++k) state->pose(i)[k] = problem.poses[i](k);
  for (int32_t j = 0; j < problem.num_features(); ++j)
    for (int k = 0; k < 2; ++k) state->landmark(j)[k] = problem.features[j](k);

  for (const core::RelativePoseConstraint& c : problem.relative_poses) {
    ceres_problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<RelativePoseCost, 3, 3, 3>(
            new RelativePoseCost(c.z, c.information)),
        nullptr, state->pose(c.from), state->pose(c.to));
  }
  std::vector<uint8_t> observed(problem.features.size(), 0);
  for (const core::Observation& o : problem.observations) {
    ceres_problem->AddResidualBlock(
        new ceres::AutoDiffCostFunction<PointObservationCost, 2, 3, 2>(
            new PointObservationCost(o.z, o.information)),
        nullptr, state->pose(o.pose), state->landmark(o.feature));
    observed[o.feature] = 1;
  }
  for (const core::GpsConstraint& g : problem.gps) {
    ceres_problem->AddResidualBlock(new ceres::AutoDiffCostFunction<PositionPriorCost, 2, 3>(
                                        new PositionPriorCost(g.z, g.information)),
                                    nullptr, state->pose(g.pose));
  }

  // Gauge, as graphslam: FIX'd poses, else pose 0.
  bool any_fixed = false;
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    if (problem.pose_fixed[i] != 0 && ceres_problem->HasParameterBlock(state->pose(i))) {
      ceres_problem->SetParameterBlockConstant(state->pose(i));
      any_fixed = true;
    }
  }
  if (!any_fixed && problem.num_poses() > 0 && ceres_problem->HasParameterBlock(state->pose(0)))
    ceres_problem->SetParameterBlockConstant(state->pose(0));

  int32_t landmarks_used = 0;
  for (int32_t j = 0; j < problem.num_features(); ++j) {
    if (observed[j] == 0) continue;
    ordering->AddElementToGroup(state->landmark(j), 0);
    ++landmarks_used;
  }
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    if (ceres_problem->HasParameterBlock(state->pose(i)))
      ordering->AddElementToGroup(state->pose(i), 1);
  }
  return landmarks_used;
}

// Records per-iteration figures (Ceres' iteration 0 is the initial
// evaluation; graphslam numbers iterations from 1, so it is skipped).
class RecordingCallback : public ceres::IterationCallback {
 public:
  // `log` (may be null, not owned) gets each iteration as a JSON line.
  explicit RecordingCallback(std::FILE* log) : log_(log) {}

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& summary) override {
    if (summary.iteration == 0) return ceres::SOLVER_CONTINUE;
    per_iteration_.push_back({{"iteration", summary.iteration},
                              {"chi2", 2.0 * summary.cost},
                              {"cost_change", summary.cost_change},
                              {"step_norm", summary.step_norm},
                              {"gradient_max_norm", summary.gradient_max_norm},
                              {"linear_solver_iterations", summary.linear_solver_iterations},
                              {"lambda", 1.0 / summary.trust_region_radius},
                              {"relative_decrease", summary.relative_decrease},
                              {"accepted", summary.step_is_successful},
                              {"seconds", summary.iteration_time_in_seconds},
                              {"solve_seconds", summary.step_solver_time_in_seconds}});
    if (log_ != nullptr) {
      nlohmann::json line = per_iteration_.back();
      line["cpu_seconds"] = tools::ProcessCpuSeconds();
      // A failed write only loses the progressive log; the report stays.
      std::fprintf(log_, "%s\n", line.dump().c_str());
      std::fflush(log_);
    }
    return ceres::SOLVER_CONTINUE;
  }
  const nlohmann::json& per_iteration() const { return per_iteration_; }
  void Clear() { per_iteration_ = nlohmann::json::array(); }

 private:
  nlohmann::json per_iteration_ = nlohmann::json::array();
  std::FILE* log_;
};

// graphslam's termination names for Ceres' messages.
std::string TerminationName(const ceres::Solver::Summary& summary) {
  const std::string& message = summary.message;
  if (message.rfind("Function tolerance", 0) == 0) return "function_tolerance";
  if (message.rfind("Gradient tolerance", 0) == 0) return "gradient_tolerance";
  if (message.rfind("Parameter tolerance", 0) == 0) return "parameter_tolerance";
  if (message.rfind("Maximum number of iterations", 0) == 0) return "max_iterations";
  if (message.rfind("Minimum trust region radius", 0) == 0) return "min_trust_region_radius";
  std::string name = ceres::TerminationTypeToString(summary.termination_type);
  for (char& c : name) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return name;
}

void ConfigureLinearSolver(const PeerOptions& options, bool fallback,
                           ceres::Solver::Options* solver_options) {
  const bool iterative = options.linear_solver == "iterative_schur";
  if (options.linear_solver == "sparse_normal_cholesky") {
    // CHOLMOD on J^T J of all unknowns: what Ceres' own pose-graph examples use.
    solver_options->linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options->preconditioner_type = ceres::JACOBI;
  } else if (!fallback) {
    solver_options->linear_solver_type =
        iterative ? ceres::ITERATIVE_SCHUR : ceres::SPARSE_SCHUR;
    solver_options->preconditioner_type = ceres::SCHUR_JACOBI;
  } else {
    solver_options->linear_solver_type = iterative ? ceres::CGNR : ceres::SPARSE_NORMAL_CHOLESKY;
    solver_options->preconditioner_type = ceres::JACOBI;
  }
}

ceres::Solver::Options BaseSolverOptions(const PeerOptions& options, int threads) {
  ceres::Solver::Options solver_options;
  solver_options.minimizer_type = ceres::TRUST_REGION;
  solver_options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = options.function_tolerance;
  solver_options.num_threads = threads;
  solver_options.eta = options.eta;
  solver_options.max_linear_solver_iterations = options.max_linear_solver_iterations;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.sparse_linear_algebra_library_type = ceres::SUITE_SPARSE;
  return solver_options;
}

// What one run measured, for the report and the summary.
struct RunFigures {
  ceres::Solver::Summary summary;
  int32_t landmarks_used = 0;
  bool fallback = false;
  int threads = 0;
  double read_seconds = 0.0, initialize_seconds = 0.0, build_seconds = 0.0;
  double optimize_cpu_seconds = 0.0, total_seconds = 0.0;
  double initial_chi2_graphslam = 0.0, final_chi2_graphslam = 0.0;
  int iterations = 0, successful_iterations = 0;
};

// At most two attempts: the Schur solver, then (pose-only graphs whose
// Schur attempt failed) the fallback. The solution stays in *state.
Status SolveWithFallback(const PeerOptions& options, const core::Problem2d& problem,
                         ceres::Solver::Options* solver_options, RecordingCallback* recorder,
                         CeresState* state, RunFigures* figures) {
  ceres::Solver::Summary& summary = figures->summary;
  for (int attempt = 0; attempt < 2; ++attempt) {
    const Clock::time_point build_start = Clock::now();
    ceres::Problem ceres_problem;  // owns the cost functions
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    figures->landmarks_used = BuildCeresProblem(problem, state, &ceres_problem, ordering.get());
    figures->build_seconds = Seconds(build_start);
    ConfigureLinearSolver(options, figures->fallback, solver_options);
    // Landmarks first; a pose-only graph lets Ceres choose (see header).
    const bool schur = options.linear_solver != "sparse_normal_cholesky";
    solver_options->linear_solver_ordering =
        schur && figures->landmarks_used > 0 ? ordering : nullptr;
    std::string error;
    if (!solver_options->IsValid(&error))
      return Status::InvalidArgument("Ceres options: " + error);
    recorder->Clear();
    const double optimize_cpu_start = tools::ProcessCpuSeconds();
    ceres::Solve(*solver_options, &ceres_problem, &summary);
    figures->optimize_cpu_seconds = tools::ProcessCpuSeconds() - optimize_cpu_start;
    const bool failed_before_start =
        summary.termination_type == ceres::FAILURE && summary.iterations.size() <= 1;
    if (!failed_before_start || figures->landmarks_used > 0 || figures->fallback) break;
    std::fprintf(stderr, "graphslam_ceres_peer: %s failed (%s); falling back\n",
                 options.linear_solver.c_str(), summary.message.c_str());
    figures->fallback = true;
  }
  if (summary.termination_type == ceres::FAILURE)
    return Status::Numerical(options.input + ": Ceres failed: " + summary.message);
  return Status::Ok();
}

nlohmann::json Report(const PeerOptions& options, const core::Problem2d& problem,
                      const RunFigures& figures, const nlohmann::json& per_iteration) {
  const ceres::Solver::Summary& summary = figures.summary;
  nlohmann::json report;
  report["peer"] = std::string("ceres ") + CERES_VERSION_STRING;
  report["input"] = options.input;
  report["format"] = "g2o";
  report["solver"] = ceres::LinearSolverTypeToString(summary.linear_solver_type_used);
  const bool iterative_solver = summary.linear_solver_type_used == ceres::ITERATIVE_SCHUR ||
                                summary.linear_solver_type_used == ceres::CGNR;
  report["preconditioner"] =
      iterative_solver ? ceres::PreconditionerTypeToString(summary.preconditioner_type_used)
                       : "none";
  report["fallback"] = figures.fallback;
  report["initial_chi2"] = 2.0 * summary.initial_cost;
  report["final_chi2"] = 2.0 * summary.final_cost;
  report["initial_chi2_graphslam_models"] = figures.initial_chi2_graphslam;
  report["final_chi2_graphslam_models"] = figures.final_chi2_graphslam;
  report["iterations"] = figures.iterations;
  report["successful_iterations"] = figures.successful_iterations;
  report["converged"] = summary.termination_type == ceres::CONVERGENCE;
  report["termination"] = TerminationName(summary);
  report["termination_message"] = summary.message;
  report["poses"] = problem.num_poses();
  report["features"] = problem.num_features();
  report["observations"] = static_cast<int64_t>(problem.observations.size());
  report["observations_used"] = static_cast<int64_t>(problem.observations.size());
  report["relative_pose_constraints"] = static_cast<int64_t>(problem.relative_poses.size());
  report["gps_constraints"] = static_cast<int64_t>(problem.gps.size());
  report["initialization"] = "odometry";
  report["residual_dimension"] = summary.num_residuals;
  report["unknowns"] = summary.num_effective_parameters_reduced;
  report["landmarks_eliminated"] = figures.landmarks_used;
  report["eta"] = options.eta;
  report["max_linear_solver_iterations"] = options.max_linear_solver_iterations;
  report["schur_structure"] = summary.schur_structure_used;
  // Sizes of the elimination groups Ceres used (first: eliminated blocks).
  report["elimination_group_sizes"] = summary.linear_solver_ordering_used;
  report["threads"] = figures.threads;
  report["seconds"] = figures.total_seconds;
  report["stage_seconds"] = {{"read", figures.read_seconds},
                             {"initialize", figures.initialize_seconds},
                             {"build", figures.build_seconds},
                             {"optimize", summary.total_time_in_seconds},
                             {"linear_solver", summary.linear_solver_time_in_seconds},
                             {"jacobian_evaluation", summary.jacobian_evaluation_time_in_seconds},
                             {"residual_evaluation", summary.residual_evaluation_time_in_seconds}};
  report["peak_rss_bytes"] = tools::PeakRssBytes();
  report["optimize_cpu_seconds"] = figures.optimize_cpu_seconds;
  report["cpu_seconds"] = tools::ProcessCpuSeconds();
  report["per_iteration"] = per_iteration;
  return report;
}

void PrintSummary(const PeerOptions& options, const core::Problem2d& problem,
                  const RunFigures& figures) {
  const ceres::Solver::Summary& summary = figures.summary;
  std::printf("graphslam_ceres_peer summary (%s)\n",
              (std::string("ceres ") + CERES_VERSION_STRING).c_str());
  std::printf("  input              %s\n", options.input.c_str());
  std::printf("  poses / features   %d / %d\n", problem.num_poses(), problem.num_features());
  std::printf("  linear solver      %s%s\n",
              ceres::LinearSolverTypeToString(summary.linear_solver_type_used),
              figures.fallback ? " (fallback)" : "");
  std::printf("  initial chi2       %.9g (graphslam models %.9g)\n", 2.0 * summary.initial_cost,
              figures.initial_chi2_graphslam);
  std::printf("  final chi2         %.9g (graphslam models %.9g)\n", 2.0 * summary.final_cost,
              figures.final_chi2_graphslam);
  std::printf("  iterations         %d (%s)\n", figures.iterations,
              TerminationName(summary).c_str());
  std::printf("  seconds            %.3f (optimize %.3f)\n", figures.total_seconds,
              summary.total_time_in_seconds);
  std::printf("  peak RSS           %.1f MiB\n", tools::PeakRssBytes() / (1024.0 * 1024.0));
}

int Run(const PeerOptions& options) {
  const Clock::time_point start = Clock::now();
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam_ceres_peer: %s\n", status.ToString().c_str());
    return tools::ExitCodeFor(status);
  };
  if (Status status = options.Validate(); !status.ok()) {
    std::fprintf(stderr, "graphslam_ceres_peer: %s\n", status.ToString().c_str());
    return tools::kExitUsage;
  }

  RunFigures figures;
  StatusOr<core::Problem2d> read = storage::ReadG2o(options.input);
  if (!read.ok()) return fail(read.status());
  core::Problem2d problem = std::move(read).value();
  figures.read_seconds = Seconds(start);
  const Clock::time_point initialize_start = Clock::now();
  if (Status status = core::InitializeProblem(&problem); !status.ok()) return fail(status);
  if (Status status = CheckSupported(problem); !status.ok()) return fail(status);
  figures.initialize_seconds = Seconds(initialize_start);
  figures.initial_chi2_graphslam = GraphSlamChi2(problem);

  figures.threads = options.threads > 0 ? options.threads : tbb::info::default_concurrency();
  ceres::Solver::Options solver_options = BaseSolverOptions(options, figures.threads);
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> iteration_log(nullptr, &std::fclose);
  if (!options.iteration_log.empty()) {
    iteration_log.reset(std::fopen(options.iteration_log.c_str(), "w"));
    if (iteration_log == nullptr)
      return fail(Status::IOError(options.iteration_log + ": cannot open the iteration log for "
                                  "writing"));
  }
  RecordingCallback recorder(iteration_log.get());
  solver_options.callbacks.push_back(&recorder);
  CeresState state;
  if (Status status =
          SolveWithFallback(options, problem, &solver_options, &recorder, &state, &figures);
      !status.ok())
    return fail(status);

  // Copy the solution back and cross-check the cost with graphslam's models.
  for (int32_t i = 0; i < problem.num_poses(); ++i)
    for (int k = 0; k < 3; ++k) problem.poses[i](k) = state.pose(i)[k];
  for (int32_t j = 0; j < problem.num_features(); ++j)
    for (int k = 0; k < 2; ++k) problem.features[j](k) = state.landmark(j)[k];
  figures.final_chi2_graphslam = GraphSlamChi2(problem);
  figures.total_seconds = Seconds(start);
  // Ceres' summary.iterations and num_successful_steps include iteration 0
  // (the initial evaluation); graphslam counts Levenberg-Marquardt steps only.
  figures.iterations = static_cast<int>(recorder.per_iteration().size());
  for (const nlohmann::json& it : recorder.per_iteration())
    if (it["accepted"].get<bool>()) ++figures.successful_iterations;
  if (!options.report.empty()) {
    if (Status status = storage::WriteStringAtomically(
            storage::Env::Default(), options.report,
            Report(options, problem, figures, recorder.per_iteration()).dump(2) + "\n");
        !status.ok())
      return fail(status);
  }
  if (!options.quiet) PrintSummary(options, problem, figures);
  return figures.summary.termination_type == ceres::CONVERGENCE ? tools::kExitOk
                                                                 : tools::kExitNotConverged;
}

}  // namespace
}  // namespace graphslam::perf

int main(int argc, char** argv) {
  // Ceres logs through glog: to stderr only, warnings and up.
  FLAGS_logtostderr = true;
  FLAGS_minloglevel = google::GLOG_WARNING;
  google::InitGoogleLogging(argv[0]);

  graphslam::perf::PeerOptions options;
  CLI::App app{"Solve a 2-D g2o graph with Ceres Solver and write a graphslam-style report"};
  app.add_option("input", options.input, "input .g2o file")->required();
  app.add_option("--linear-solver", options.linear_solver,
                 "sparse_schur, iterative_schur or sparse_normal_cholesky")
      ->capture_default_str();
  app.add_option("--report", options.report, "run report (.json)");
  app.add_option("--max-iterations", options.max_iterations, "Levenberg-Marquardt iterations")
      ->capture_default_str();
  app.add_option("--function-tolerance", options.function_tolerance,
                 "stop when |cost change| / cost is below this")
      ->capture_default_str();
  app.add_option("--threads", options.threads, "Ceres threads (0: all cores)")
      ->capture_default_str();
  app.add_option("--eta", options.eta,
                 "ITERATIVE_SCHUR forcing: CG stops at |r| <= eta |r0| (Ceres' default)")
      ->capture_default_str();
  app.add_option("--max-linear-iterations", options.max_linear_solver_iterations,
                 "ITERATIVE_SCHUR: CG iterations per step at most (Ceres' default)")
      ->capture_default_str();
  app.add_option("--iteration-log", options.iteration_log,
                 "one JSON line per iteration, flushed as it ends (survives a timeout)");
  app.add_flag("-q,--quiet", options.quiet, "no summary on the terminal");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    const int code = app.exit(error);
    return code == 0 ? graphslam::tools::kExitOk : graphslam::tools::kExitUsage;
  }
  return graphslam::perf::Run(options);
}
