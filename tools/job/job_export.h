// The steps of a job's export stage (docs/jobs.md, "Outputs"), each a
// function of the optimized JobData; tools/job/job_runner.cc's StageExport
// calls them in order and writes the report.
//
// Time in the TUM files. A run whose input has time stamps of its own
// (MRCLAM, native logs with times) keeps them, so runs recorded at the same
// time share one clock. A run without (g2o and iSAM inputs: the pose index;
// simulate: the simulator's time, k * dt from 0 in every run) gets a
// synthetic clock that is monotonic across the job's runs: its relative time
// s (the simulator's time, or the pose index in seconds) plus an offset, the
// first such run at 0 and each next one starting 1 s after the previous one
// (estimate and ground truth) ended:
//   t = offset_r + s,   offset_r = offset_{r'} + max(s_last, s_gt_last)_{r'} + 1
// with r' the previous synthetic run. The ground-truth file of a run gets the
// same offset, so `evo_ape tum RUN_groundtruth.tum RUN.tum` matches them.
// (The errors in report.json match on the relative times.)
//
// THREAD SAFETY: reentrant. ALLOCATION: O(problem).
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "core/status.h"
#include "tools/job/job_data.h"
#include "tools/trajectory_metrics.h"

namespace graphslam::tools::job {

// The poses of `run` with their relative time: the input's stamp, or the
// pose index within the run when the stamp is not finite.
std::vector<StampedPose2> Stamped(const core::Problem2d& problem, const RunInfo& run);

// Per run: the offset added to its relative times in the TUM files (above).
std::vector<double> ExportTimeOffsets(const JobData& data);

// Writes OUTPUT/trajectories/<run>.tum and, for a run with ground truth,
// <run>_groundtruth.tum, with the times above.
[[nodiscard]] Status WriteRunTrajectories(const JobData& data, const std::string& output);

// Squared position errors summed over runs (all poses, and indoor ones).
struct ErrorSums {
  double indoor_sum = 0, all_sum = 0;
  int64_t indoor_count = 0, all_count = 0;
};
double Rmse(double sum, int64_t count);

// What the report says about the runs.
struct RunsReport {
  nlohmann::json runs = nlohmann::json::array();
  nlohmann::json joint_trajectory_errors = nlohmann::json::array();
  ErrorSums sums;
};
// Per-run entries (poses, component, GPS, errors, files) and, per component,
// the errors after one joint alignment; warnings are appended to `warnings`.
RunsReport ReportRuns(const JobData& data, nlohmann::json* warnings);

// The error sums of every run of `data` (the GPS ablation's solve).
ErrorSums SumRunErrors(const JobData& data);

// report.json's robot_sightings (null when there were none).
nlohmann::json RobotSightingsReport(const JobData& data);

// report.json's features: the map against the ground-truth landmarks.
nlohmann::json FeatureErrorsReport(const JobData& data, const std::vector<uint8_t>& excluded);

// Writes the run name table (storage/pcd_run_names.h) beside every .pcd among
// `map_files` in `output`; returns the names of the tables written.
[[nodiscard]] StatusOr<std::vector<std::string>> WriteMapRunNames(
    const JobData& data, const std::string& output, const std::vector<std::string>& map_files);

}  // namespace graphslam::tools::job
