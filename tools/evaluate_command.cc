#include "tools/evaluate_command.h"

#include <CLI/CLI.hpp>
#include <cmath>
#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <utility>
#include <vector>

#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/mrclam_reader.h"
#include "storage/trajectory_format.h"
#include "tools/exit_codes.h"
#include "tools/ground_truth.h"
#include "tools/option_checks.h"
#include "tools/output_paths.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools {
namespace {

Status ValidateOptions(const EvaluateCommandOptions& options) {
  if (options.trajectory.empty()) return Status::InvalidArgument("--trajectory is required");
  const bool tum_truth = !options.ground_truth.empty();
  const bool mrclam_truth = !options.mrclam.empty();
  if (tum_truth == mrclam_truth) {
    return Status::InvalidArgument(
        "give exactly one ground truth: --ground-truth GT.tum or --mrclam DIR");
  }
  if (options.ground_truth_format != "auto") {
    if (Status status = storage::ParseTrajectoryFormat(options.ground_truth_format).status();
        !status.ok())
      return Status::InvalidArgument("--ground-truth-format: " + status.message());
  }
  if (!options.ground_truth_times.empty() && !tum_truth) {
    return Status::InvalidArgument("--ground-truth-times needs --ground-truth POSES.txt (KITTI)");
  }
  if (mrclam_truth && !options.ground_truth_features.empty()) {
    return Status::InvalidArgument(
        "--ground-truth-features does not go with --mrclam (the landmarks come from "
        "Landmark_Groundtruth.dat)");
  }
  if (!options.ground_truth_features.empty() && options.features.empty()) {
    return Status::InvalidArgument("--ground-truth-features needs --features EST.csv");
  }
  if (!options.features.empty() && tum_truth && options.ground_truth_features.empty()) {
    return Status::InvalidArgument("--features needs --ground-truth-features GT.csv");
  }
  if (options.robot < 1 || options.robot > 5) {
    return Status::InvalidArgument("--robot must be 1..5, got " + std::to_string(options.robot));
  }
  return Status::Ok();
}

// NaN is not JSON: missing figures become null.
nlohmann::json Number(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json(nullptr);
}

nlohmann::json TransformJson(const Eigen::Isometry2d& transform) {
  return {{"x", transform.translation().x()},
          {"y", transform.translation().y()},
          {"theta", RotationAngle(transform)}};
}

// The ground truth: MRCLAM's (Vicon poses and landmark survey), or a
// trajectory file with an optional features CSV.
struct GroundTruth {
  std::vector<StampedPose2> poses;
  std::map<int64_t, core::Point2> features;
  bool have_features = false;
};

StatusOr<GroundTruth> ReadTruth(const EvaluateCommandOptions& options) {
  GroundTruth truth;
  if (!options.mrclam.empty()) {
    GS_ASSIGN_OR_RETURN(storage::MrclamGroundTruth mrclam,
                        storage::ReadMrclamGroundTruth(options.mrclam, options.robot));
    truth.poses.reserve(mrclam.poses.size());
    for (size_t i = 0; i < mrclam.poses.size(); ++i) {
      truth.poses.push_back(StampedPose2{mrclam.stamps[i], mrclam.poses[i]});
    }
    truth.features = std::move(mrclam.landmarks);
    truth.have_features = true;
    return truth;
  }
  GS_ASSIGN_OR_RETURN(truth.poses,
                      ReadGroundTruth({options.ground_truth, options.ground_truth_format,
                                       options.ground_truth_times}));
  if (!options.ground_truth_features.empty()) {
    GS_ASSIGN_OR_RETURN(truth.features, ReadFeaturesCsv(options.ground_truth_features));
    truth.have_features = true;
  }
  return truth;
}

// What the comparison found, for the report and the summary.
struct Evaluation {
  size_t estimated_poses = 0;
  size_t truth_poses = 0;
  TrajectoryErrors errors;
  bool features = false;  // landmarks compared
  FeatureErrors feature_errors;
  size_t excluded = 0;  // features the estimate marks excluded
};

nlohmann::json ReportJson(const EvaluateCommandOptions& options, const Evaluation& e) {
  const TrajectoryErrors& errors = e.errors;
  nlohmann::json report;
  report["trajectory"] = options.trajectory;
  report["ground_truth"] = options.mrclam.empty() ? options.ground_truth : options.mrclam;
  if (!options.mrclam.empty()) report["robot"] = options.robot;
  report["estimated_poses"] = static_cast<int64_t>(e.estimated_poses);
  report["ground_truth_poses"] = static_cast<int64_t>(e.truth_poses);
  report["runs"] = errors.runs;
  report["matched_poses"] = errors.matched;
  report["unmatched_poses"] = errors.unmatched;
  report["max_time_difference_s"] = errors.max_time_difference;
  report["position_rmse_m"] = errors.position_rmse;
  report["position_mean_m"] = errors.position_mean;
  report["position_max_m"] = errors.position_max;
  report["heading_rmse_rad"] = errors.heading_rmse_rad;
  report["heading_rmse_deg"] = errors.heading_rmse_rad * 180.0 / std::numbers::pi;
  report["alignment"] = TransformJson(errors.alignment);
  if (e.features) {
    const FeatureErrors& f = e.feature_errors;
    report["features"] = {{"estimated", options.features},
                          {"matched", f.matched},
                          {"missing", f.missing},
                          {"extra", f.extra},
                          {"excluded", static_cast<int64_t>(e.excluded)},
                          {"rmse_trajectory_aligned_m", Number(f.rmse_trajectory_aligned)},
                          {"rmse_self_aligned_m", Number(f.rmse_self_aligned)},
                          {"self_alignment", TransformJson(f.self_alignment)}};
  }
  return report;
}

void PrintEvaluation(const Evaluation& e) {
  const TrajectoryErrors& errors = e.errors;
  std::printf("graphslam evaluate summary\n");
  std::printf("  matched poses      %lld of %zu (%lld unmatched, tolerance %.3g s, %lld run(s))\n",
              static_cast<long long>(errors.matched), e.estimated_poses,
              static_cast<long long>(errors.unmatched), errors.max_time_difference,
              static_cast<long long>(errors.runs));
  std::printf("  position RMSE      %.4f m (mean %.4f m, max %.4f m)\n", errors.position_rmse,
              errors.position_mean, errors.position_max);
  std::printf("  heading RMSE       %.5f rad (%.3f deg)\n", errors.heading_rmse_rad,
              errors.heading_rmse_rad * 180.0 / std::numbers::pi);
  std::printf("  alignment          x %.3f m, y %.3f m, theta %.5f rad\n",
              errors.alignment.translation().x(), errors.alignment.translation().y(),
              RotationAngle(errors.alignment));
  if (e.features) {
    const FeatureErrors& f = e.feature_errors;
    std::printf("  landmarks          %lld matched, %lld missing, %lld extra, %zu excluded\n",
                static_cast<long long>(f.matched), static_cast<long long>(f.missing),
                static_cast<long long>(f.extra), e.excluded);
    std::printf("  landmark RMSE      %.4f m (trajectory alignment), %.4f m (own alignment)\n",
                f.rmse_trajectory_aligned, f.rmse_self_aligned);
  }
}

}  // namespace

void AddEvaluateCommand(CLI::App* app, EvaluateCommandOptions* options, int* exit_code) {
  CLI::App* evaluate = app->add_subcommand(
      "evaluate", "Trajectory and landmark RMSE of an estimate against ground truth");
  evaluate->add_option("--trajectory", options->trajectory, "estimated trajectory (TUM)")
      ->required();
  evaluate->add_option("--ground-truth", options->ground_truth,
                       "true trajectory (TUM or KITTI poses)");
  evaluate->add_option("--ground-truth-format", options->ground_truth_format,
                       "format of --ground-truth: auto, tum, kitti")
      ->capture_default_str();
  evaluate->add_option("--ground-truth-times", options->ground_truth_times,
                       "KITTI times file (default: stamps are frame indices)");
  evaluate->add_option("--features", options->features, "estimated features (.csv)");
  evaluate->add_option("--ground-truth-features", options->ground_truth_features,
                       "true features (.csv)");
  evaluate->add_option("--mrclam", options->mrclam, "MRCLAM dataset folder (ground truth)");
  evaluate->add_option("--robot", options->robot, "MRCLAM robot number")
      ->check(Integer(1, 5))
      ->capture_default_str();
  evaluate->add_option("--max-time-difference", options->max_time_difference,
                       "pose matching tolerance [s] (default: min(0.05, GT spacing / 2))")
      ->check(PositiveReal());
  evaluate->add_option("--report", options->report, "evaluation report (.json)");
  evaluate->add_flag("-q,--quiet", options->quiet, "no figures on the terminal");
  evaluate->add_flag("-v,--verbose", options->verbosity, "more log detail (repeatable)");
  evaluate->callback([options, exit_code]() { *exit_code = RunEvaluateCommand(*options); });
}

int RunEvaluateCommand(const EvaluateCommandOptions& options) {
  SetLogVerbosity(options.verbosity);
  SetQuietLogging(options.quiet);
  auto fail = [](const Status& status) {
    std::fprintf(stderr, "graphslam evaluate: %s\n", status.ToString().c_str());
    return ExitCodeFor(status);
  };
  if (Status status = ValidateOptions(options); !status.ok()) {
    std::fprintf(stderr, "graphslam evaluate: %s\n", status.message().c_str());
    return kExitUsage;
  }

  if (Status status = CheckOutputPaths({{"--report", options.report}}); !status.ok())
    return fail(status);
  // Read everything first.
  StatusOr<std::vector<StampedPose2>> estimated = ReadTum(options.trajectory);
  if (!estimated.ok()) return fail(estimated.status());
  StatusOr<GroundTruth> truth = ReadTruth(options);
  if (!truth.ok()) return fail(truth.status());
  Evaluation evaluation;
  std::map<int64_t, core::Point2> estimated_features;
  std::vector<int64_t> excluded;
  evaluation.features = !options.features.empty() && truth->have_features;
  if (evaluation.features) {
    StatusOr<std::map<int64_t, core::Point2>> features =
        ReadFeaturesCsv(options.features, &excluded);
    if (!features.ok()) return fail(features.status());
    estimated_features = std::move(features).value();
  }

  // Compare.
  TrajectoryMatchOptions match;
  match.max_time_difference = options.max_time_difference;
  StatusOr<TrajectoryErrors> compared = CompareTrajectories(*estimated, truth->poses, match);
  if (!compared.ok()) return fail(compared.status());
  evaluation.errors = *compared;
  evaluation.estimated_poses = estimated->size();
  evaluation.truth_poses = truth->poses.size();
  evaluation.excluded = excluded.size();
  if (evaluation.features) {
    evaluation.feature_errors =
        CompareFeatures(estimated_features, truth->features, evaluation.errors.alignment);
  }

  if (!options.report.empty()) {
    const std::string report = ReportJson(options, evaluation).dump(2) + "\n";
    if (Status status =
            storage::WriteStringAtomically(storage::Env::Default(), options.report, report);
        !status.ok()) {
      return fail(status);
    }
  }
  if (!options.quiet) PrintEvaluation(evaluation);
  return kExitOk;
}

}  // namespace graphslam::tools
