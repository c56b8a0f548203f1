// graphslam_gtsam_peer: solves a g2o graph with GTSAM (Dellaert, Kaess et
// al., https://gtsam.org) so that `graphslam solve` can be compared against
// a third well-known peer on identical data (docs/peers.md). GTSAM is not in
// Debian: it is built from source outside this repository and found with
// -DGTSAM_DIR=PREFIX/lib/cmake/GTSAM (perf/CMakeLists.txt).
//
//   graphslam_gtsam_peer INPUT.g2o --report REPORT.json [--3d]
//                        [--optimizer gn|lm] [--relative-error-tol T]
//                        [--max-iterations N] [-q]
//
// Pipeline: storage::ReadG2o / ReadG2o3d -> core::InitializeProblem(3d)
// (the file's vertices; missing guesses chained as graphslam does) -> one
// gtsam::NonlinearFactorGraph -> GaussNewtonOptimizer or
// LevenbergMarquardtOptimizer with GTSAM's default linear solver (multifrontal
// Cholesky, COLAMD ordering) -> a JSON report with the keys of
// `graphslam solve --report` that perf/peer_suite.py reads.
//
// Factors and their conventions:
//   EDGE_SE2        gtsam::BetweenFactor<Pose2>, e = Log(z^-1 x_i^-1 x_j) in
//                   GTSAM's (x, y, theta) order, the file's information.
//   EDGE_SE2_XY     PointInPoseFactor below: e = R_i^T (l - t_i) - z.
//   EDGE_SE3:QUAT   gtsam::BetweenFactor<Pose3>. GTSAM's tangent is (omega, t),
//                   g2o's error (t, vec q) with vec q = omega / 2 to first
//                   order, so the information becomes M^T Omega M with
//                   e_g2o = M e_gtsam, M = [0 I; I/2 0].
// These agree with g2o's residuals to first order only, so the chi2 the
// report gives is evaluated with graphslam's own models (g2o's conventions)
// at GTSAM's solution: the number is comparable across peers.
// Gauge: a prior of information 1e12 on the first pose (or on each FIX'd
// pose) at its initial value, left out of the reported chi2.
//
// Exit codes as the graphslam tool (tools/exit_codes.h): 0 solved, 1 usage,
// 2 bad input, 3 I/O error.
#include <gtsam/config.h>
#include <gtsam/geometry/Point2.h>
#include <gtsam/geometry/Pose2.h>
#include <gtsam/geometry/Pose3.h>
#include <gtsam/nonlinear/GaussNewtonOptimizer.h>
#include <gtsam/nonlinear/LevenbergMarquardtOptimizer.h>
#include <gtsam/nonlinear/NonlinearFactor.h>
#include <gtsam/nonlinear/NonlinearFactorGraph.h>
#include <gtsam/nonlinear/PriorFactor.h>
#include <gtsam/nonlinear/Values.h>
#include <gtsam/slam/BetweenFactor.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/initialization.h"
#include "core/initialization_3d.h"
#include "core/point_observation_model.h"
#include "core/pose_factors.h"
#include "core/problem.h"
#include "core/problem_3d.h"
#include "core/status.h"
#include "storage/atomic_file.h"
#include "storage/env.h"
#include "storage/g2o_3d_reader.h"
#include "storage/g2o_reader.h"
#include "tools/exit_codes.h"

namespace graphslam::perf {
namespace {

using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

struct PeerOptions {
  std::string input;
  std::string report;
  bool three_d = false;
  std::string optimizer = "gn";      // gn | lm
  double relative_error_tol = 1e-6;  // graphslam's --function-tolerance
  int max_iterations = 1000;
  bool quiet = false;
};

// A landmark seen from a 2-D pose (g2o EDGE_SE2_XY): e = R^T (l - t) - z.
// gtsam::Pose2::transformTo gives the value and both Jacobians.
class PointInPoseFactor : public gtsam::NoiseModelFactorN<gtsam::Pose2, gtsam::Point2> {
 public:
  PointInPoseFactor(gtsam::Key pose, gtsam::Key point, const gtsam::Point2& z,
                    const gtsam::SharedNoiseModel& model)
      : gtsam::NoiseModelFactorN<gtsam::Pose2, gtsam::Point2>(model, pose, point), z_(z) {}

  gtsam::Vector evaluateError(const gtsam::Pose2& pose, const gtsam::Point2& point,
                              gtsam::OptionalMatrixType h_pose,
                              gtsam::OptionalMatrixType h_point) const override {
    return pose.transformTo(point, h_pose, h_point) - z_;
  }

 private:
  gtsam::Point2 z_;
};

// Keys: poses 0..P-1, then features P..P+F-1 (graphslam's indices, not ids).
gtsam::Key FeatureKey(int32_t num_poses, int32_t feature) {
  return static_cast<gtsam::Key>(num_poses) + static_cast<gtsam::Key>(feature);
}

gtsam::SharedNoiseModel Information(const gtsam::Matrix& information) {
  return gtsam::noiseModel::Gaussian::Information(information);
}

// The gauge: FIX'd poses, else pose 0 (as graphslam and the Ceres peer).
std::vector<int32_t> AnchoredPoses(const std::vector<uint8_t>& fixed) {
  std::vector<int32_t> anchored;
  for (size_t i = 0; i < fixed.size(); ++i)
    if (fixed[i] != 0) anchored.push_back(static_cast<int32_t>(i));
  if (anchored.empty() && !fixed.empty()) anchored.push_back(0);
  return anchored;
}

StatusOr<std::pair<gtsam::NonlinearFactorGraph, gtsam::Values>> Build2d(
    const core::Problem2d& problem) {
  if (!problem.motions.empty() || !problem.gps.empty() || !problem.pose_range_bearings.empty())
    return Status::NotSupported(problem.source +
                                ": the GTSAM peer supports EDGE_SE2 and EDGE_SE2_XY only");
  gtsam::NonlinearFactorGraph graph;
  gtsam::Values values;
  const int32_t poses = problem.num_poses();
  for (int32_t i = 0; i < poses; ++i)
    values.insert(i, gtsam::Pose2(problem.poses[i](0), problem.poses[i](1), problem.poses[i](2)));
  for (const core::RelativePoseConstraint& c : problem.relative_poses)
    graph.emplace_shared<gtsam::BetweenFactor<gtsam::Pose2>>(
        c.from, c.to, gtsam::Pose2(c.z(0), c.z(1), c.z(2)), Information(c.information));
  std::vector<uint8_t> seen(problem.features.size(), 0);
  for (const core::Observation& o : problem.observations) {
    if (o.kind != core::ObservationKind::kPointXY)
      return Status::NotSupported(problem.source + ":" + std::to_string(o.line) + ": " +
                                  core::ObservationKindName(o.kind) +
                                  " observation; expected EDGE_SE2_XY");
    graph.emplace_shared<PointInPoseFactor>(o.pose, FeatureKey(poses, o.feature),
                                            gtsam::Point2(o.z), Information(o.information));
    seen[o.feature] = 1;
  }
  for (int32_t j = 0; j < problem.num_features(); ++j)
    if (seen[j] != 0) values.insert(FeatureKey(poses, j), gtsam::Point2(problem.features[j]));
  for (int32_t i : AnchoredPoses(problem.pose_fixed))
    graph.emplace_shared<gtsam::PriorFactor<gtsam::Pose2>>(
        i, values.at<gtsam::Pose2>(i), gtsam::noiseModel::Isotropic::Precision(3, 1e12));
  return std::make_pair(std::move(graph), std::move(values));
}

gtsam::Pose3 ToGtsam(const core::Pose3& pose) {
  return gtsam::Pose3(gtsam::Rot3(pose.q), gtsam::Point3(pose.t));
}

core::Pose3 FromGtsam(const gtsam::Pose3& pose) {
  core::Pose3 out;
  out.q = pose.rotation().toQuaternion();
  out.t = pose.translation();
  return out;
}

StatusOr<std::pair<gtsam::NonlinearFactorGraph, gtsam::Values>> Build3d(
    const core::Problem3d& problem) {
  if (!problem.observations.empty() || !problem.gps.empty())
    return Status::NotSupported(problem.source +
                                ": the GTSAM peer supports 3-D pose graphs (EDGE_SE3:QUAT) only");
  gtsam::NonlinearFactorGraph graph;
  gtsam::Values values;
  for (int32_t i = 0; i < problem.num_poses(); ++i) values.insert(i, ToGtsam(problem.poses[i]));
  gtsam::Matrix6 m = gtsam::Matrix6::Zero();  // e_g2o = M e_gtsam (header)
  m.topRightCorner<3, 3>().setIdentity();
  m.bottomLeftCorner<3, 3>() = 0.5 * gtsam::Matrix3::Identity();
  for (const core::RelativePose3Constraint& c : problem.relative_poses) {
    const gtsam::Matrix6 information = m.transpose() * c.information * m;
    graph.emplace_shared<gtsam::BetweenFactor<gtsam::Pose3>>(c.from, c.to, ToGtsam(c.z),
                                                             Information(information));
  }
  for (int32_t i : AnchoredPoses(problem.pose_fixed))
    graph.emplace_shared<gtsam::PriorFactor<gtsam::Pose3>>(
        i, values.at<gtsam::Pose3>(i), gtsam::noiseModel::Isotropic::Precision(6, 1e12));
  return std::make_pair(std::move(graph), std::move(values));
}

// chi2 in g2o's conventions (graphslam's models) of `values`.
double Chi2(core::Problem2d* problem, const gtsam::Values& values) {
  const int32_t poses = problem->num_poses();
  for (int32_t i = 0; i < poses; ++i) {
    const gtsam::Pose2 p = values.at<gtsam::Pose2>(i);
    problem->poses[i] = core::Pose2(p.x(), p.y(), p.theta());
  }
  for (int32_t j = 0; j < problem->num_features(); ++j)
    if (values.exists(FeatureKey(poses, j)))
      problem->features[j] = values.at<gtsam::Point2>(FeatureKey(poses, j));
  double chi2 = core::PoseFactorsChi2(*problem, problem->poses);
  for (const core::Observation& o : problem->observations) {
    Eigen::Vector2d e;
    core::EvaluatePointObservation(problem->poses[o.pose], problem->features[o.feature], o.z, &e,
                                   nullptr, nullptr);
    chi2 += e.dot(o.information * e);
  }
  return chi2;
}

double Chi2(core::Problem3d* problem, const gtsam::Values& values) {
  for (int32_t i = 0; i < problem->num_poses(); ++i)
    problem->poses[i] = FromGtsam(values.at<gtsam::Pose3>(i));
  return core::PoseFactorsChi2(*problem, problem->poses);
}

struct Solved {
  gtsam::Values values;
  int iterations = 0;
  double optimize_seconds = 0.0;
};

// Params: gtsam::GaussNewtonParams or LevenbergMarquardtParams, with the
// optimizer that takes them.
template <class Optimizer, class Params>
Solved OptimizeWith(const PeerOptions& options, const gtsam::NonlinearFactorGraph& graph,
                    const gtsam::Values& initial) {
  Solved solved;
  const Clock::time_point start = Clock::now();
  Params params;
  params.relativeErrorTol = options.relative_error_tol;
  params.maxIterations = options.max_iterations;
  Optimizer optimizer(graph, initial, params);
  solved.values = optimizer.optimize();
  solved.iterations = static_cast<int>(optimizer.iterations());
  solved.optimize_seconds = Seconds(start);
  return solved;
}

Solved Optimize(const PeerOptions& options, const gtsam::NonlinearFactorGraph& graph,
                const gtsam::Values& initial) {
  if (options.optimizer == "lm")
    return OptimizeWith<gtsam::LevenbergMarquardtOptimizer, gtsam::LevenbergMarquardtParams>(
        options, graph, initial);
  return OptimizeWith<gtsam::GaussNewtonOptimizer, gtsam::GaussNewtonParams>(options, graph,
                                                                             initial);
}

template <class Problem>
StatusOr<nlohmann::json> Run(const PeerOptions& options, Problem problem) {
  const Clock::time_point start = Clock::now();
  StatusOr<std::pair<gtsam::NonlinearFactorGraph, gtsam::Values>> built =
      [&]() -> StatusOr<std::pair<gtsam::NonlinearFactorGraph, gtsam::Values>> {
    if constexpr (std::is_same_v<Problem, core::Problem2d>) {
      GS_RETURN_IF_ERROR(core::InitializeProblem(&problem));
      return Build2d(problem);
    } else {
      GS_RETURN_IF_ERROR(core::InitializeProblem3d(&problem));
      return Build3d(problem);
    }
  }();
  if (!built.ok()) return built.status();
  const auto& [graph, initial] = built.value();
  const double initial_chi2 = Chi2(&problem, initial);
  const Solved solved = Optimize(options, graph, initial);
  const double final_chi2 = Chi2(&problem, solved.values);
  nlohmann::json report;
  report["peer"] = std::string("gtsam ") + GTSAM_VERSION_STRING;
  report["optimizer"] = options.optimizer == "lm" ? "levenberg_marquardt" : "gauss_newton";
  report["input"] = options.input;
  report["poses"] = problem.num_poses();
  report["features"] = problem.num_features();
  report["initial_chi2"] = initial_chi2;
  report["final_chi2"] = final_chi2;
  report["iterations"] = solved.iterations;
  report["optimize_seconds"] = solved.optimize_seconds;
  report["total_seconds"] = Seconds(start);
  return report;
}

int Main(int argc, char** argv) {
  PeerOptions options;
  CLI::App app{"Solves a g2o graph with GTSAM (a peer for perf/peer_suite.py)"};
  app.add_option("input", options.input, "g2o file")->required();
  app.add_option("--report", options.report, "JSON report to write")->required();
  app.add_flag("--3d", options.three_d, "the file is a 3-D graph (EDGE_SE3:QUAT)");
  app.add_option("--optimizer", options.optimizer, "gn (Gauss-Newton) or lm")
      ->check(CLI::IsMember({"gn", "lm"}));
  app.add_option("--relative-error-tol", options.relative_error_tol,
                 "stop when the error falls by less than this fraction")
      ->check(CLI::PositiveNumber);
  app.add_option("--max-iterations", options.max_iterations)->check(CLI::PositiveNumber);
  app.add_flag("-q,--quiet", options.quiet);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? 0 : tools::kExitUsage;
  }
  const auto read_and_run = [&options]() -> StatusOr<nlohmann::json> {
    if (options.three_d) {
      GS_ASSIGN_OR_RETURN(core::Problem3d problem, storage::ReadG2o3d(options.input));
      return Run(options, std::move(problem));
    }
    GS_ASSIGN_OR_RETURN(core::Problem2d problem, storage::ReadG2o(options.input));
    return Run(options, std::move(problem));
  };
  StatusOr<nlohmann::json> report = read_and_run();
  if (!report.ok()) {
    std::fprintf(stderr, "graphslam_gtsam_peer: %s\n", report.status().ToString().c_str());
    return tools::ExitCodeFor(report.status());
  }
  if (Status written = storage::WriteStringAtomically(storage::Env::Default(), options.report,
                                                      report.value().dump(2) + "\n");
      !written.ok()) {
    std::fprintf(stderr, "graphslam_gtsam_peer: %s\n", written.ToString().c_str());
    return tools::kExitIOError;
  }
  if (!options.quiet)
    std::printf("%s: chi2 %.6f after %d iterations\n", options.input.c_str(),
                report.value()["final_chi2"].get<double>(),
                report.value()["iterations"].get<int>());
  return 0;
}

}  // namespace
}  // namespace graphslam::perf

int main(int argc, char** argv) { return graphslam::perf::Main(argc, argv); }
