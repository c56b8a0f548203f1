#include "tools/job/job_data.h"

#include <GeographicLib/LocalCartesian.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <numeric>
#include <sstream>

#include "core/interpolated_pose_range_bearing_model.h"
#include "core/range_bearing_model.h"
#include "core/unidentified_features.h"
#include "storage/env.h"
#include "storage/format_detection.h"
#include "tools/campus_simulator.h"
#include "tools/ground_truth.h"

namespace graphslam::tools::job {
namespace {

// One input: a problem holding one or more consecutive runs.
struct Block {
  core::Problem2d problem;
  std::vector<std::pair<std::string, int32_t>> runs;  // name, poses
  std::vector<std::vector<StampedPose2>> ground_truth;  // per run, or empty
  std::map<int64_t, core::Point2> ground_truth_features;
  std::vector<std::vector<uint8_t>> indoor;  // per run, or empty
  // MRCLAM (one run): what the reader skipped, and the robot sightings.
  storage::MrclamReadStats mrclam;
  RunSightings sightings;
  core::InformationRepairs repairs;  // solver.repair_information
};

bool Inside(const std::array<double, 4>& box, double x, double y) {
  return x >= box[0] && x <= box[2] && y >= box[1] && y <= box[3];
}

StatusOr<Block> SimulateRun(const RunSpec& spec) {
  StatusOr<SimulatedCampus> simulated = SimulateCampus(spec.simulate);
  if (!simulated.ok())
    return Status::InvalidArgument("run '" + spec.name + "' (job line " +
                                   std::to_string(spec.line) + "): " +
                                   simulated.status().message());
  SimulatedCampus campus = std::move(simulated).value();
  Block block;
  const int runs = spec.simulate.runs;
  block.ground_truth.resize(static_cast<size_t>(runs));
  block.indoor.resize(static_cast<size_t>(runs));
  std::vector<int32_t> counts(static_cast<size_t>(runs), 0);
  for (size_t i = 0; i < campus.true_poses.size(); ++i) {
    const auto run = static_cast<size_t>(campus.run_of_pose[i]);
    ++counts[run];
    StampedPose2 truth;
    truth.stamp = campus.problem.pose_stamps[i];
    truth.pose = campus.true_poses[i];
    block.ground_truth[run].push_back(truth);
    const bool indoor = spec.gps_denied_region &&
                        Inside(*spec.gps_denied_region, truth.pose.x(), truth.pose.y());
    block.indoor[run].push_back(indoor ? 1 : 0);
  }
  // GPS is not received indoors.
  if (spec.gps_denied_region) {
    std::vector<core::GpsConstraint> kept;
    for (const core::GpsConstraint& gps : campus.problem.gps) {
      const core::Pose2& truth = campus.true_poses[static_cast<size_t>(gps.pose)];
      if (!Inside(*spec.gps_denied_region, truth.x(), truth.y())) kept.push_back(gps);
    }
    campus.problem.gps = std::move(kept);
  }
  for (int r = 0; r < runs; ++r)
    block.runs.emplace_back(runs == 1 ? spec.name : spec.name + "_" + std::to_string(r + 1),
                            counts[static_cast<size_t>(r)]);
  for (size_t f = 0; f < campus.true_features.size(); ++f)
    block.ground_truth_features[campus.problem.feature_ids[f]] = campus.true_features[f];
  block.problem = std::move(campus.problem);
  block.problem.source = "simulate:" + spec.name;
  return block;
}

StatusOr<Block> ReadRun(const RunSpec& spec, bool repair_information) {
  if (spec.format == "simulate") return SimulateRun(spec);
  StatusOr<storage::InputFormat> format = storage::ParseInputFormat(spec.format);
  if (!format.ok()) return format.status();
  storage::MrclamOptions mrclam;
  mrclam.robot = spec.robot;
  // Each robot in its own frame: its Vicon pose would place it for free.
  mrclam.start_at_ground_truth = false;
  if (spec.range_sigma) mrclam.measurement_information(0, 0) = 1.0 / (*spec.range_sigma * *spec.range_sigma);
  if (spec.bearing_sigma)
    mrclam.measurement_information(1, 1) = 1.0 / (*spec.bearing_sigma * *spec.bearing_sigma);
  storage::MrclamReadStats stats;
  core::InformationRepairs repairs;
  StatusOr<core::Problem2d> read = storage::ReadProblem(spec.path, *format, mrclam, &stats,
                                                        repair_information ? &repairs : nullptr);
  if (!read.ok()) return read.status();
  Block block;
  block.repairs = std::move(repairs);
  block.problem = std::move(read).value();
  if (*format == storage::InputFormat::kMrclam) {
    std::error_code error;
    block.sightings.dataset = std::filesystem::weakly_canonical(spec.path, error).string();
    if (error) block.sightings.dataset = spec.path;
    block.sightings.robot = spec.robot;
    block.sightings.information = mrclam.measurement_information;
    block.sightings.sightings = std::move(stats.robot_sightings);
    block.mrclam = std::move(stats);
  }
  if (block.problem.num_poses() == 0)
    return Status::InvalidArgument(spec.path + ": run '" + spec.name + "' has no poses");
  block.runs.emplace_back(spec.name, block.problem.num_poses());
  block.indoor.emplace_back();
  if (!spec.ground_truth.empty()) {
    StatusOr<std::vector<StampedPose2>> truth = ReadGroundTruth(
        {spec.ground_truth, spec.ground_truth_format, spec.ground_truth_times});
    if (!truth.ok()) return truth.status();
    block.ground_truth.push_back(std::move(truth).value());
  } else if (*format == storage::InputFormat::kMrclam &&
             storage::Env::Default()->FileExists(spec.path + "/Robot" +
                                                 std::to_string(spec.robot) + "_Groundtruth.dat")) {
    // MRCLAM carries its Vicon ground truth: used for the report's errors.
    // (Its landmark survey is not: two of its labels are swapped, see
    // docs/benchmarks.md.)
    StatusOr<storage::MrclamGroundTruth> truth =
        storage::ReadMrclamGroundTruth(spec.path, spec.robot);
    if (!truth.ok()) return truth.status();
    std::vector<StampedPose2> poses;
    for (size_t i = 0; i < truth->stamps.size(); ++i) poses.push_back({truth->stamps[i], truth->poses[i]});
    block.ground_truth.push_back(std::move(poses));
  } else {
    block.ground_truth.emplace_back();
  }
  return block;
}

// Splits a CSV line on commas (and blanks).
std::vector<std::string> Fields(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) {
    const size_t begin = field.find_first_not_of(" \t\r");
    const size_t end = field.find_last_not_of(" \t\r");
    fields.push_back(begin == std::string::npos ? "" : field.substr(begin, end - begin + 1));
  }
  return fields;
}

bool ParseNumber(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size() && std::isfinite(*value);
}

// Attaches the fixes of `gps` to the poses [first, first + count) of `problem`.
Status AttachGps(const GpsSource& gps, int32_t first, int32_t count,
                 std::optional<std::array<double, 3>>* origin, core::Problem2d* problem) {
  GS_ASSIGN_OR_RETURN(const std::string text,
                      storage::ReadFileToString(storage::Env::Default(), gps.path,
                                                gps.path + ": cannot open the GPS file"));
  std::istringstream in(text);
  std::vector<std::pair<double, int32_t>> stamps;
  for (int32_t i = first; i < first + count; ++i) {
    const double t = problem->pose_stamps[static_cast<size_t>(i)];
    if (!std::isfinite(t))
      return Status::InvalidArgument(gps.path + ": the run's input has no time stamps (pose " +
                                     std::to_string(problem->pose_ids[static_cast<size_t>(i)]) +
                                     "); expected timed poses to attach GPS fixes to");
    stamps.emplace_back(t, i);
  }
  std::sort(stamps.begin(), stamps.end());
  const Eigen::Matrix2d information = Eigen::Matrix2d::Identity() / (gps.sigma * gps.sigma);
  std::string line;
  int32_t number = 0;
  bool header_allowed = true;
  std::optional<GeographicLib::LocalCartesian> enu;
  while (std::getline(in, line)) {
    ++number;
    const size_t start = line.find_first_not_of(" \t\r");
    if (start == std::string::npos || line[start] == '#') continue;
    const std::vector<std::string> fields = Fields(line);
    double values[3];
    bool numeric = fields.size() >= 3;
    for (size_t k = 0; numeric && k < 3; ++k) numeric = ParseNumber(fields[k], &values[k]);
    if (!numeric) {
      if (header_allowed) {
        header_allowed = false;
        continue;
      }
      return Status::Corruption(gps.path + ":" + std::to_string(number) + ": '" + line +
                                "'; expected t," +
                                (gps.frame == "enu" ? "east,north" : "lat,lon") + " numbers");
    }
    header_allowed = false;
    double x = values[1], y = values[2];
    if (gps.frame == "wgs84") {
      if (std::abs(values[1]) > 90 || std::abs(values[2]) > 180)
        return Status::Corruption(gps.path + ":" + std::to_string(number) +
                                  ": latitude/longitude out of range; expected |lat| <= 90, "
                                  "|lon| <= 180");
      if (!origin->has_value()) *origin = std::array<double, 3>{values[1], values[2], 0.0};
      if (!enu) enu.emplace((**origin)[0], (**origin)[1], (**origin)[2]);
      double z = 0;
      enu->Forward(values[1], values[2], 0.0, x, y, z);
    }
    // The pose nearest in time.
    auto it = std::lower_bound(stamps.begin(), stamps.end(),
                               std::make_pair(values[0], std::numeric_limits<int32_t>::min()));
    int32_t best = -1;
    double best_dt = gps.max_time_difference;
    for (auto candidate : {it, it == stamps.begin() ? it : std::prev(it)}) {
      if (candidate == stamps.end()) continue;
      const double dt = std::abs(candidate->first - values[0]);
      if (dt <= best_dt) {
        best_dt = dt;
        best = candidate->second;
      }
    }
    if (best < 0) continue;  // no pose near that time
    core::GpsConstraint constraint;
    constraint.pose = best;
    constraint.z = Eigen::Vector2d(x, y);
    constraint.information = information;
    constraint.line = number;
    problem->gps.push_back(constraint);
  }
  return Status::Ok();
}

// Appends `part` to `merged`; features are identified by id.
void Append(const core::Problem2d& part, std::map<int64_t, int32_t>* feature_index,
            core::Problem2d* merged) {
  const int32_t offset = merged->num_poses();
  for (int32_t i = 0; i < part.num_poses(); ++i) {
    const auto k = static_cast<size_t>(i);
    merged->AddPose(part.pose_ids[k], part.poses[k], part.pose_initialized[k] != 0,
                    part.pose_lines[k], part.pose_stamps[k]);
    merged->pose_fixed.back() = part.pose_fixed[k];
  }
  std::vector<int32_t> feature_map(static_cast<size_t>(part.num_features()));
  for (int32_t f = 0; f < part.num_features(); ++f) {
    const auto k = static_cast<size_t>(f);
    if (part.feature_ids[k] == core::kNoFeatureId) {  // unknown correspondence: its own
      feature_map[k] = merged->AddFeature(core::kNoFeatureId, part.features[k],
                                          part.feature_initialized[k] != 0);
      continue;
    }
    auto [it, inserted] = feature_index->emplace(part.feature_ids[k], merged->num_features());
    if (inserted) merged->AddFeature(part.feature_ids[k], part.features[k], part.feature_initialized[k] != 0);
    feature_map[k] = it->second;
  }
  for (core::RelativePoseConstraint c : part.relative_poses) {
    c.from += offset;
    c.to += offset;
    merged->relative_poses.push_back(c);
  }
  for (core::VelocityMotionConstraint c : part.motions) {
    c.from += offset;
    c.to += offset;
    merged->motions.push_back(c);
  }
  for (core::GpsConstraint c : part.gps) {
    c.pose += offset;
    merged->gps.push_back(c);
  }
  for (core::PoseRangeBearingConstraint c : part.pose_range_bearings) {
    c.from += offset;
    c.to += offset;
    if (c.interpolated()) c.to_next += offset;
    merged->pose_range_bearings.push_back(c);
  }
  for (core::Observation o : part.observations) {
    o.pose += offset;
    o.feature = feature_map[static_cast<size_t>(o.feature)];
    merged->observations.push_back(o);
  }
}

int32_t Find(std::vector<int32_t>* parent, int32_t x) {
  while ((*parent)[static_cast<size_t>(x)] != x) {
    (*parent)[static_cast<size_t>(x)] =
        (*parent)[static_cast<size_t>((*parent)[static_cast<size_t>(x)])];
    x = (*parent)[static_cast<size_t>(x)];
  }
  return x;
}

// Union-find over runs; components numbered by their first run.
void FindComponents(JobData* data) {
  const core::Problem2d& problem = data->problem;
  const auto runs = static_cast<int32_t>(data->runs.size());
  std::vector<int32_t> run_of_pose(static_cast<size_t>(problem.num_poses()));
  for (int32_t r = 0; r < runs; ++r) {
    const RunInfo& run = data->runs[static_cast<size_t>(r)];
    for (int32_t i = 0; i < run.num_poses; ++i)
      run_of_pose[static_cast<size_t>(run.first_pose + i)] = r;
  }
  std::vector<int32_t> parent(static_cast<size_t>(runs));
  std::iota(parent.begin(), parent.end(), 0);
  auto unite = [&](int32_t a, int32_t b) {
    a = Find(&parent, a);
    b = Find(&parent, b);
    if (a != b) parent[static_cast<size_t>(std::max(a, b))] = std::min(a, b);
  };
  std::vector<int32_t> feature_run(static_cast<size_t>(problem.num_features()), -1);
  for (const core::Observation& o : problem.observations) {
    const int32_t r = run_of_pose[static_cast<size_t>(o.pose)];
    int32_t& seen = feature_run[static_cast<size_t>(o.feature)];
    if (seen < 0) seen = r;
    else unite(seen, r);
  }
  // Odometry never crosses runs, but relative-pose files could tie them.
  for (const core::RelativePoseConstraint& c : problem.relative_poses)
    unite(run_of_pose[static_cast<size_t>(c.from)], run_of_pose[static_cast<size_t>(c.to)]);
  // Robots seeing each other.
  for (const core::PoseRangeBearingConstraint& c : problem.pose_range_bearings)
    unite(run_of_pose[static_cast<size_t>(c.from)], run_of_pose[static_cast<size_t>(c.to)]);
  int32_t first_gps_run = -1;
  for (int32_t r = 0; r < runs; ++r) {
    if (data->runs[static_cast<size_t>(r)].gps_fixes == 0) continue;
    if (first_gps_run < 0) first_gps_run = r;
    else unite(first_gps_run, r);
  }
  std::map<int32_t, int32_t> numbering;
  for (int32_t r = 0; r < runs; ++r) {
    const int32_t root = Find(&parent, r);
    auto [it, inserted] = numbering.emplace(root, static_cast<int32_t>(numbering.size()));
    data->runs[static_cast<size_t>(r)].component = it->second;
  }
  data->num_components = static_cast<int32_t>(numbering.size());
}

// Gauge per component (see the header).
void SetGauge(JobData* data) {
  core::Problem2d& problem = data->problem;
  std::fill(problem.pose_fixed.begin(), problem.pose_fixed.end(), 0);
  std::vector<uint8_t> has_gps(static_cast<size_t>(data->num_components), 0);
  for (const RunInfo& run : data->runs)
    if (run.gps_fixes > 0) has_gps[static_cast<size_t>(run.component)] = 1;
  std::vector<uint8_t> anchored(static_cast<size_t>(data->num_components), 0);
  for (const RunInfo& run : data->runs) {
    const auto c = static_cast<size_t>(run.component);
    if (has_gps[c] || anchored[c] || run.num_poses == 0) continue;
    problem.pose_fixed[static_cast<size_t>(run.first_pose)] = 1;
    anchored[c] = 1;
  }
}

// ids: false: every observation gets an uninitialized feature of its own
// (placed at first sight by the initialization).
void StripIds(core::Problem2d* problem) {
  problem->features.clear();
  problem->feature_ids.clear();
  problem->feature_initialized.clear();
  for (core::Observation& o : problem->observations)
    o.feature = problem->AddFeature(core::kNoFeatureId, core::Point2::Zero(), false);
}

}  // namespace

void UpdateComponents(JobData* data) {
  FindComponents(data);
  SetGauge(data);
}

namespace {

// GPS fixes per run of the block.
std::vector<int64_t> GpsFixesPerRun(const Block& block) {
  std::vector<int64_t> fixes(block.runs.size(), 0);
  std::vector<size_t> run_of_pose;
  for (size_t r = 0; r < block.runs.size(); ++r)
    run_of_pose.insert(run_of_pose.end(), static_cast<size_t>(block.runs[r].second), r);
  for (const core::GpsConstraint& gps : block.problem.gps)
    ++fixes[run_of_pose[static_cast<size_t>(gps.pose)]];
  return fixes;
}

// The block's runs, from pose `first` of data->problem on; a run name used
// twice is an error naming the spec's line.
Status AddRuns(const JobSpec& job, const RunSpec& spec, const Block& block, int32_t first,
               JobData* data) {
  const bool unidentified = core::CountUnidentifiedObservations(block.problem).count > 0;
  const std::vector<int64_t> fixes = GpsFixesPerRun(block);
  const bool synthetic_time =
      spec.format == "simulate" ||
      !std::all_of(block.problem.pose_stamps.begin(), block.problem.pose_stamps.end(),
                   [](double t) { return std::isfinite(t); });
  for (size_t r = 0; r < block.runs.size(); ++r) {
    RunInfo run;
    run.name = block.runs[r].first;
    run.first_pose = first;
    run.num_poses = block.runs[r].second;
    run.gps_fixes = fixes[r];
    run.has_ground_truth = !block.ground_truth[r].empty();
    run.synthetic_time = synthetic_time;
    run.information_repairs = block.repairs;
    if (run.has_ground_truth) data->ground_truth[run.name] = block.ground_truth[r];
    run.indoor = block.indoor[r];
    run.unidentified = unidentified;
    run.unknown_barcodes_skipped = block.mrclam.unknown_barcodes_skipped;
    run.unknown_barcode_lines = block.mrclam.unknown_barcode_lines;
    first += run.num_poses;
    for (const RunInfo& other : data->runs)
      if (other.name == run.name)
        return Status::InvalidArgument(job.path + ":" + std::to_string(spec.line) +
                                       ": run name '" + run.name + "' is used twice");
    data->runs.push_back(std::move(run));
  }
  return Status::Ok();
}

// Fresh ids for the features of unknown correspondence; pose ids 0..P-1,
// past the feature ids if they would collide.
void AssignIds(core::Problem2d* problem) {
  int64_t next = 0;
  for (int64_t id : problem->feature_ids) next = std::max(next, id + 1);
  for (int64_t& id : problem->feature_ids)
    if (id == core::kNoFeatureId) id = next++;
  int64_t base = 0;
  for (int64_t id : problem->feature_ids)
    if (id >= 0 && id < problem->num_poses()) {
      base = *std::max_element(problem->feature_ids.begin(), problem->feature_ids.end()) + 1;
      break;
    }
  for (int32_t i = 0; i < problem->num_poses(); ++i)
    problem->pose_ids[static_cast<size_t>(i)] = base + i;
}

}  // namespace

StatusOr<JobData> LoadJobData(const JobSpec& job) {
  JobData data;
  data.problem.source = job.path;
  std::map<int64_t, int32_t> feature_index;
  std::vector<RunSightings> sightings;
  for (const RunSpec& spec : job.runs) {
    StatusOr<Block> read = ReadRun(spec, job.solver.repair_information);
    if (!read.ok()) return read.status();
    Block block = std::move(read).value();
    if (!spec.ids) {
      StripIds(&block.problem);
      block.ground_truth_features.clear();
    }
    if (spec.gps) {
      if (block.runs.size() != 1)
        return Status::InvalidArgument(job.path + ":" + std::to_string(spec.gps->line) +
                                       ": a GPS file needs a single-run input");
      GS_RETURN_IF_ERROR(
          AttachGps(*spec.gps, 0, block.problem.num_poses(), &data.enu_origin, &block.problem));
    }
    const int32_t first = data.problem.num_poses();
    if (!block.sightings.dataset.empty()) {
      block.sightings.first_pose = first;
      block.sightings.num_poses = block.problem.num_poses();
      sightings.push_back(std::move(block.sightings));
    }
    Append(block.problem, &feature_index, &data.problem);
    GS_RETURN_IF_ERROR(AddRuns(job, spec, block, first, &data));
    data.ground_truth_features.insert(block.ground_truth_features.begin(),
                                      block.ground_truth_features.end());
  }
  core::Problem2d& problem = data.problem;
  AssignIds(&problem);
  if (job.robot_sightings)
    data.sightings = AddRobotSightings(sightings, kDefaultSightingMaxTimeDifference,
                                       kDefaultSightingMaxInterpolationGap, &problem);
  FindComponents(&data);
  SetGauge(&data);
  return data;
}

core::Problem2d ExtractComponent(const JobData& data, int32_t component,
                                 std::vector<int32_t>* pose_map,
                                 std::vector<int32_t>* feature_map) {
  const core::Problem2d& problem = data.problem;
  core::Problem2d sub;
  sub.source = problem.source;
  pose_map->clear();
  feature_map->clear();
  std::vector<int32_t> pose_index(static_cast<size_t>(problem.num_poses()), -1);
  for (const RunInfo& run : data.runs) {
    if (run.component != component) continue;
    for (int32_t i = run.first_pose; i < run.first_pose + run.num_poses; ++i) {
      const auto k = static_cast<size_t>(i);
      pose_index[k] = sub.AddPose(problem.pose_ids[k], problem.poses[k],
                                  problem.pose_initialized[k] != 0, problem.pose_lines[k],
                                  problem.pose_stamps[k]);
      sub.pose_fixed.back() = problem.pose_fixed[k];
      pose_map->push_back(i);
    }
  }
  std::vector<int32_t> feature_index(static_cast<size_t>(problem.num_features()), -1);
  for (const core::Observation& o : problem.observations)
    if (pose_index[static_cast<size_t>(o.pose)] >= 0) feature_index[static_cast<size_t>(o.feature)] = 0;
  for (int32_t f = 0; f < problem.num_features(); ++f) {
    const auto k = static_cast<size_t>(f);
    if (feature_index[k] < 0) continue;
    feature_index[k] = sub.AddFeature(problem.feature_ids[k], problem.features[k],
                                      problem.feature_initialized[k] != 0);
    feature_map->push_back(f);
  }
  auto in = [&](int32_t pose) { return pose_index[static_cast<size_t>(pose)] >= 0; };
  auto map = [&](int32_t pose) { return pose_index[static_cast<size_t>(pose)]; };
  for (core::RelativePoseConstraint c : problem.relative_poses) {
    if (!in(c.from)) continue;
    c.from = map(c.from);
    c.to = map(c.to);
    sub.relative_poses.push_back(c);
  }
  for (core::VelocityMotionConstraint c : problem.motions) {
    if (!in(c.from)) continue;
    c.from = map(c.from);
    c.to = map(c.to);
    sub.motions.push_back(c);
  }
  for (core::GpsConstraint c : problem.gps) {
    if (!in(c.pose)) continue;
    c.pose = map(c.pose);
    sub.gps.push_back(c);
  }
  for (core::PoseRangeBearingConstraint c : problem.pose_range_bearings) {
    if (!in(c.from)) continue;
    c.from = map(c.from);
    c.to = map(c.to);
    if (c.interpolated()) c.to_next = map(c.to_next);
    sub.pose_range_bearings.push_back(c);
  }
  for (core::Observation o : problem.observations) {
    if (!in(o.pose)) continue;
    o.pose = map(o.pose);
    o.feature = feature_index[static_cast<size_t>(o.feature)];
    sub.observations.push_back(o);
  }
  return sub;
}

void ScatterComponent(const core::Problem2d& sub, const std::vector<int32_t>& pose_map,
                      const std::vector<int32_t>& feature_map, core::Problem2d* problem) {
  for (size_t i = 0; i < pose_map.size(); ++i) {
    problem->poses[static_cast<size_t>(pose_map[i])] = sub.poses[i];
    problem->pose_initialized[static_cast<size_t>(pose_map[i])] = sub.pose_initialized[i];
  }
  for (size_t f = 0; f < feature_map.size(); ++f) {
    problem->features[static_cast<size_t>(feature_map[f])] = sub.features[f];
    problem->feature_initialized[static_cast<size_t>(feature_map[f])] = sub.feature_initialized[f];
  }
}

core::Problem2d RunTrajectory(const core::Problem2d& problem, const RunInfo& run) {
  core::Problem2d trajectory;
  for (int32_t i = run.first_pose; i < run.first_pose + run.num_poses; ++i) {
    const auto k = static_cast<size_t>(i);
    trajectory.AddPose(problem.pose_ids[k], problem.poses[k], true, problem.pose_lines[k],
                       problem.pose_stamps[k]);
  }
  return trajectory;
}

namespace {

// The landmark position implied by one observation from `pose`.
core::Point2 FirstSight(const core::Pose2& pose, const core::Observation& o) {
  return core::InvertObservation(o.kind, pose, o.z);
}

void Apply(const Eigen::Isometry2d& t, core::Pose2* pose) {
  const Eigen::Vector2d p = t * pose->head<2>();
  const double angle = std::atan2(t.linear()(1, 0), t.linear()(0, 0));
  *pose = core::Pose2(p.x(), p.y(), std::remainder(pose->z() + angle, 2 * M_PI));
}

}  // namespace

namespace {

// AlignRunFrames' state: the component's runs as pose ranges of `sub`, the
// first observation of each feature overall (its run owns the feature's
// guess) and by each run (for the correspondences), and which runs are
// placed.
class RunFrameAligner {
 public:
  explicit RunFrameAligner(core::Problem2d* sub) : sub_(sub) {}

  // The runs of `component`; false if their poses are not all of `sub`.
  bool Index(const JobData& data, int32_t component) {
    int32_t next = 0;
    for (const RunInfo& run : data.runs) {
      if (run.component != component) continue;
      ranges_.emplace_back(next, run.num_poses);
      next += run.num_poses;
    }
    if (next != sub_->num_poses()) return false;
    const size_t num_runs = ranges_.size();
    run_of_pose_.resize(static_cast<size_t>(sub_->num_poses()));
    for (size_t r = 0; r < num_runs; ++r)
      for (int32_t i = 0; i < ranges_[r].second; ++i)
        run_of_pose_[static_cast<size_t>(ranges_[r].first + i)] = static_cast<int32_t>(r);
    num_features_ = static_cast<size_t>(sub_->num_features());
    first_run_.assign(num_features_, -1);
    first_by_run_.assign(num_runs, std::vector<int64_t>(num_features_, -1));
    for (size_t k = 0; k < sub_->observations.size(); ++k) {
      const core::Observation& o = sub_->observations[k];
      const auto f = static_cast<size_t>(o.feature);
      const auto r = static_cast<size_t>(run_of_pose_[static_cast<size_t>(o.pose)]);
      if (first_run_[f] < 0) first_run_[f] = static_cast<int32_t>(r);
      if (first_by_run_[r][f] < 0) first_by_run_[r][f] = static_cast<int64_t>(k);
    }
    placed_.assign(num_runs, 0);
    return true;
  }

  // GPS: a run with >= 2 fixes goes onto them. Returns the runs moved.
  int PlaceOnGps() {
    int moved = 0;
    for (size_t r = 0; r < ranges_.size(); ++r) {
      std::vector<core::Point2> own, reference;
      for (const core::GpsConstraint& gps : sub_->gps) {
        if (run_of_pose_[static_cast<size_t>(gps.pose)] != static_cast<int32_t>(r)) continue;
        own.push_back(sub_->poses[static_cast<size_t>(gps.pose)].head<2>());
        reference.push_back(gps.z);
      }
      if (own.size() < 2) continue;
      Move(r, AlignRigid(own, reference));
      placed_[r] = 1;
      ++moved;
    }
    return moved;
  }

  // Greedily, the unplaced run with the most landmarks and robot sightings
  // shared with placed runs next (the first run is the frame when no run
  // was placed on GPS). Returns the runs moved.
  int PlaceByCorrespondences() {
    const size_t num_runs = ranges_.size();
    if (std::find(placed_.begin(), placed_.end(), 1) == placed_.end() && num_runs > 0)
      placed_[0] = 1;
    int moved = 0;
    std::vector<core::Point2> own, reference;
    for (;;) {
      size_t best = num_runs, best_count = 1;
      for (size_t r = 0; r < num_runs; ++r) {
        if (placed_[r]) continue;
        Correspondences(r, &own, &reference);
        if (own.size() > best_count) {
          best = r;
          best_count = own.size();
        }
      }
      if (best == num_runs) break;
      Correspondences(best, &own, &reference);
      Move(best, AlignRigid(own, reference));
      placed_[best] = 1;
      ++moved;
    }
    return moved;
  }

 private:
  core::Point2 Sight(int64_t k) const {
    const core::Observation& o = sub_->observations[static_cast<size_t>(k)];
    return FirstSight(sub_->poses[static_cast<size_t>(o.pose)], o);
  }

  void Move(size_t r, const Eigen::Isometry2d& t) {
    for (int32_t i = ranges_[r].first; i < ranges_[r].first + ranges_[r].second; ++i)
      Apply(t, &sub_->poses[static_cast<size_t>(i)]);
    for (size_t f = 0; f < num_features_; ++f)
      if (first_run_[f] == static_cast<int32_t>(r)) sub_->features[f] = t * sub_->features[f];
  }

  // Run r's points against the placed runs' for the same landmark or robot.
  void Correspondences(size_t r, std::vector<core::Point2>* own,
                       std::vector<core::Point2>* reference) const {
    own->clear();
    reference->clear();
    for (size_t f = 0; f < num_features_; ++f) {
      if (first_by_run_[r][f] < 0) continue;
      for (size_t q = 0; q < ranges_.size(); ++q) {
        if (!placed_[q] || first_by_run_[q][f] < 0) continue;
        own->push_back(Sight(first_by_run_[r][f]));
        reference->push_back(Sight(first_by_run_[q][f]));
        break;
      }
    }
    const std::vector<core::Pose2>& poses = sub_->poses;
    for (const core::PoseRangeBearingConstraint& c : sub_->pose_range_bearings) {
      const auto observer = static_cast<size_t>(run_of_pose_[static_cast<size_t>(c.from)]);
      const auto observed = static_cast<size_t>(run_of_pose_[static_cast<size_t>(c.to)]);
      const core::Point2 seen = core::InvertRangeBearing(poses[static_cast<size_t>(c.from)], c.z);
      const core::Point2 at =
          c.interpolated()
              ? core::InterpolatePosition(poses[static_cast<size_t>(c.to)],
                                          poses[static_cast<size_t>(c.to_next)], c.alpha)
              : core::Point2(poses[static_cast<size_t>(c.to)].head<2>());
      if (observer == r && placed_[observed]) {
        own->push_back(seen);
        reference->push_back(at);
      } else if (observed == r && placed_[observer]) {
        own->push_back(at);
        reference->push_back(seen);
      }
    }
  }

  core::Problem2d* const sub_;
  std::vector<std::pair<int32_t, int32_t>> ranges_;  // per run: first pose, count
  std::vector<int32_t> run_of_pose_;
  size_t num_features_ = 0;
  std::vector<int32_t> first_run_;
  std::vector<std::vector<int64_t>> first_by_run_;
  std::vector<uint8_t> placed_;
};

}  // namespace

int AlignRunFrames(const JobData& data, int32_t component, core::Problem2d* sub) {
  RunFrameAligner aligner(sub);
  if (!aligner.Index(data, component)) return 0;
  const int on_gps = aligner.PlaceOnGps();
  return on_gps + aligner.PlaceByCorrespondences();
}

void RemoveGps(JobData* data) {
  data->problem.gps.clear();
  for (RunInfo& run : data->runs) run.gps_fixes = 0;
  FindComponents(data);
  SetGauge(data);
}

}  // namespace graphslam::tools::job
