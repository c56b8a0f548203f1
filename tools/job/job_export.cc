#include "tools/job/job_export.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <utility>

#include "storage/env.h"
#include "storage/pcd_run_names.h"
#include "storage/tum_writer.h"
#include "tools/job/robot_sightings.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct RunErrors {
  bool valid = false;
  TrajectoryErrors errors;
  ErrorSums sums;
};

RunErrors EvaluateRun(const JobData& data, const RunInfo& run) {
  RunErrors result;
  auto truth = data.ground_truth.find(run.name);
  if (truth == data.ground_truth.end()) return result;
  const std::vector<StampedPose2> estimated = Stamped(data.problem, run);
  StatusOr<TrajectoryErrors> errors = CompareTrajectories(estimated, truth->second);
  if (!errors.ok()) return result;
  result.valid = true;
  result.errors = *errors;
  for (size_t k = 0; k < errors->estimated_index.size(); ++k) {
    const auto e = static_cast<size_t>(errors->estimated_index[k]);
    const auto g = static_cast<size_t>(errors->ground_truth_index[k]);
    const Eigen::Vector2d p = errors->alignment * estimated[e].pose.head<2>();
    const double squared = (p - truth->second[g].pose.head<2>()).squaredNorm();
    result.sums.all_sum += squared;
    ++result.sums.all_count;
    if (e < run.indoor.size() && run.indoor[e]) {
      result.sums.indoor_sum += squared;
      ++result.sums.indoor_count;
    }
  }
  return result;
}

void Add(const ErrorSums& from, ErrorSums* to) {
  to->indoor_sum += from.indoor_sum;
  to->indoor_count += from.indoor_count;
  to->all_sum += from.all_sum;
  to->all_count += from.all_count;
}

// A trajectory as a problem of its own for the TUM writer, times shifted.
core::Problem2d Shifted(const std::vector<StampedPose2>& poses, double offset) {
  core::Problem2d trajectory;
  for (size_t i = 0; i < poses.size(); ++i)
    trajectory.AddPose(static_cast<int64_t>(i), poses[i].pose, true, 0, offset + poses[i].stamp);
  return trajectory;
}

// Per component, every run with ground truth after ONE rigid alignment of
// them all (tools/trajectory_metrics.h, CompareTrajectoriesJointly).
json JointErrors(const JobData& data, json* warnings,
                 std::map<std::string, TrajectoryErrors>* joint_of_run) {
  json joint_errors = json::array();
  for (int32_t c = 0; c < data.num_components; ++c) {
    std::vector<std::vector<StampedPose2>> estimated, truth;
    std::vector<std::string> names;
    for (const RunInfo& run : data.runs) {
      if (run.component != c || !data.ground_truth.contains(run.name)) continue;
      estimated.push_back(Stamped(data.problem, run));
      truth.push_back(data.ground_truth.at(run.name));
      names.push_back(run.name);
    }
    if (estimated.empty()) continue;
    StatusOr<JointTrajectoryErrors> joint = CompareTrajectoriesJointly(estimated, truth);
    if (!joint.ok()) {
      warnings->push_back("component " + std::to_string(c) +
                          ": no joint trajectory error: " + joint.status().message());
      continue;
    }
    json per_run = json::array();
    for (size_t k = 0; k < joint->runs.size(); ++k) {
      const TrajectoryErrors& e = joint->runs[k];
      (*joint_of_run)[names[k]] = e;
      per_run.push_back({{"name", names[k]},
                         {"matched_poses", e.matched},
                         {"position_rmse_m", e.position_rmse},
                         {"heading_rmse_rad", e.heading_rmse_rad},
                         {"position_max_m", e.position_max}});
    }
    joint_errors.push_back(
        {{"component", c},
         {"runs", per_run},
         {"matched_poses", joint->matched},
         {"position_rmse_m", joint->position_rmse},
         {"heading_rmse_rad", joint->heading_rmse_rad},
         {"alignment",
          {{"x", joint->alignment.translation().x()},
           {"y", joint->alignment.translation().y()},
           {"theta", RotationAngle(joint->alignment)}}}});
  }
  return joint_errors;
}

// The report entry of one run without its errors; warnings about it.
json RunEntry(const JobData& data, const RunInfo& run, bool tied, json* warnings) {
  if (!tied && data.runs.size() > 1)
    warnings->push_back("run " + run.name +
                        " is tied to no other run (no shared landmark, no robot sighting, no "
                        "GPS): it is mapped on its own, in its own frame");
  json entry = {{"name", run.name},
                {"poses", run.num_poses},
                {"component", run.component},
                {"gps_fixes", run.gps_fixes},
                {"tied", tied},
                {"time", run.synthetic_time ? "synthetic" : "input"},
                {"trajectory", "trajectories/" + run.name + ".tum"}};
  if (data.ground_truth.contains(run.name))
    entry["ground_truth_trajectory"] = "trajectories/" + run.name + "_groundtruth.tum";
  if (run.information_repairs.count > 0) {
    entry["information_repairs"] = run.information_repairs.count;
    entry["information_repair_lines"] = run.information_repairs.first_lines;
  }
  if (run.unknown_barcodes_skipped > 0) {
    entry["unknown_barcodes_skipped"] = run.unknown_barcodes_skipped;
    entry["unknown_barcode_lines"] = run.unknown_barcode_lines;
    warnings->push_back("run " + run.name + ": " +
                        std::to_string(run.unknown_barcodes_skipped) +
                        " measurements with a barcode in no row of Barcodes.dat were skipped "
                        "(first: " + run.unknown_barcode_lines.front() + ")");
  }
  return entry;
}

// The run's own errors into `entry`.
void AddRunErrors(const JobData& data, const RunInfo& run, json* entry, RunsReport* report) {
  const RunErrors errors = EvaluateRun(data, run);
  if (!errors.valid) return;
  (*entry)["position_rmse_m"] = errors.errors.position_rmse;
  (*entry)["heading_rmse_rad"] = errors.errors.heading_rmse_rad;
  (*entry)["position_max_m"] = errors.errors.position_max;
  (*entry)["matched_poses"] = errors.errors.matched;
  if (errors.sums.indoor_count > 0) {
    (*entry)["indoor_poses"] = errors.sums.indoor_count;
    (*entry)["indoor_position_rmse_m"] = Rmse(errors.sums.indoor_sum, errors.sums.indoor_count);
  }
  Add(errors.sums, &report->sums);
}

}  // namespace

std::vector<StampedPose2> Stamped(const core::Problem2d& problem, const RunInfo& run) {
  std::vector<StampedPose2> poses;
  for (int32_t i = run.first_pose; i < run.first_pose + run.num_poses; ++i) {
    StampedPose2 p;
    const double stamp = problem.pose_stamps[static_cast<size_t>(i)];
    p.stamp = std::isfinite(stamp) ? stamp : i - run.first_pose;
    p.pose = problem.poses[static_cast<size_t>(i)];
    poses.push_back(p);
  }
  return poses;
}

std::vector<double> ExportTimeOffsets(const JobData& data) {
  std::vector<double> offsets;
  double next = 0.0;  // where the next synthetic run starts
  for (const RunInfo& run : data.runs) {
    if (!run.synthetic_time) {
      offsets.push_back(0.0);
      continue;
    }
    offsets.push_back(next);
    double last = run.num_poses > 0 ? Stamped(data.problem, run).back().stamp : 0.0;
    if (auto truth = data.ground_truth.find(run.name);
        truth != data.ground_truth.end() && !truth->second.empty())
      last = std::max(last, truth->second.back().stamp);
    next += last + 1.0;
  }
  return offsets;
}

Status WriteRunTrajectories(const JobData& data, const std::string& output) {
  const fs::path folder = fs::path(output) / "trajectories";
  GS_RETURN_IF_ERROR(storage::Env::Default()->CreateDir(folder.string()));
  const std::vector<double> offsets = ExportTimeOffsets(data);
  for (size_t r = 0; r < data.runs.size(); ++r) {
    const RunInfo& run = data.runs[r];
    GS_RETURN_IF_ERROR(storage::WriteTum(Shifted(Stamped(data.problem, run), offsets[r]),
                                         (folder / (run.name + ".tum")).string()));
    auto truth = data.ground_truth.find(run.name);
    if (truth == data.ground_truth.end()) continue;
    GS_RETURN_IF_ERROR(storage::WriteTum(Shifted(truth->second, offsets[r]),
                                         (folder / (run.name + "_groundtruth.tum")).string()));
  }
  return Status::Ok();
}

double Rmse(double sum, int64_t count) {
  return count > 0 ? std::sqrt(sum / static_cast<double>(count)) : std::nan("");
}

RunsReport ReportRuns(const JobData& data, json* warnings) {
  RunsReport report;
  std::map<std::string, TrajectoryErrors> joint_of_run;
  report.joint_trajectory_errors = JointErrors(data, warnings, &joint_of_run);
  std::vector<int> runs_in_component(static_cast<size_t>(data.num_components), 0);
  for (const RunInfo& run : data.runs) ++runs_in_component[static_cast<size_t>(run.component)];
  for (const RunInfo& run : data.runs) {
    const bool tied =
        runs_in_component[static_cast<size_t>(run.component)] > 1 || run.gps_fixes > 0;
    json entry = RunEntry(data, run, tied, warnings);
    if (auto joint = joint_of_run.find(run.name); joint != joint_of_run.end()) {
      entry["joint_position_rmse_m"] = joint->second.position_rmse;
      entry["joint_heading_rmse_rad"] = joint->second.heading_rmse_rad;
    }
    AddRunErrors(data, run, &entry, &report);
    report.runs.push_back(entry);
  }
  return report;
}

ErrorSums SumRunErrors(const JobData& data) {
  ErrorSums sums;
  for (const RunInfo& run : data.runs) Add(EvaluateRun(data, run).sums, &sums);
  return sums;
}

json RobotSightingsReport(const JobData& data) {
  if (data.sightings.constraints + data.sightings.robot_not_in_job +
          data.sightings.no_pose_at_stamp == 0)
    return nullptr;
  std::vector<int32_t> run_of_pose(static_cast<size_t>(data.problem.num_poses()));
  for (size_t r = 0; r < data.runs.size(); ++r)
    for (int32_t i = 0; i < data.runs[r].num_poses; ++i)
      run_of_pose[static_cast<size_t>(data.runs[r].first_pose + i)] = static_cast<int32_t>(r);
  json pairs = json::array();
  for (const auto& [pair, count] : CountSightingsPerRunPair(data.problem, run_of_pose))
    pairs.push_back({{"runs",
                      {data.runs[static_cast<size_t>(pair.first)].name,
                       data.runs[static_cast<size_t>(pair.second)].name}},
                     {"constraints", count}});
  return {{"constraints", data.sightings.constraints},
          {"interpolated", data.sightings.interpolated},
          {"robot_not_in_job", data.sightings.robot_not_in_job},
          {"no_pose_at_stamp", data.sightings.no_pose_at_stamp},
          {"standstill_repeats_merged", data.sightings.standstill_repeats_merged},
          {"pairs", pairs}};
}

json FeatureErrorsReport(const JobData& data, const std::vector<uint8_t>& excluded) {
  std::map<int64_t, core::Point2> estimated;
  for (int32_t f = 0; f < data.problem.num_features(); ++f)
    if (!excluded[static_cast<size_t>(f)])
      estimated[data.problem.feature_ids[static_cast<size_t>(f)]] =
          data.problem.features[static_cast<size_t>(f)];
  const FeatureErrors features =
      CompareFeatures(estimated, data.ground_truth_features, Eigen::Isometry2d::Identity());
  return {{"matched", features.matched}, {"rmse_self_aligned_m", features.rmse_self_aligned}};
}

StatusOr<std::vector<std::string>> WriteMapRunNames(const JobData& data,
                                                    const std::string& output,
                                                    const std::vector<std::string>& map_files) {
  std::vector<std::string> names, written;
  for (const RunInfo& run : data.runs) names.push_back(run.name);
  for (const std::string& file : map_files) {
    if (fs::path(file).extension() != ".pcd") continue;
    const std::string pcd = (fs::path(output) / file).string();
    GS_RETURN_IF_ERROR(storage::WritePcdRunNames(pcd, names));
    written.push_back(fs::path(storage::PcdRunNamesPath(pcd)).filename().string());
  }
  return written;
}

}  // namespace graphslam::tools::job
