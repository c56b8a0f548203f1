#include "storage/mrclam_reader.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <unordered_map>
#include <utility>

#include "core/logging.h"
#include "core/unidentified_features.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;

// Subjects 1..5 of Barcodes.dat are the robots of MRCLAM (Leung et al. 2011).
constexpr int64_t kLastRobotSubject = 5;

std::string RobotFile(const std::string& folder, int robot, const char* suffix) {
  return folder + "/Robot" + std::to_string(robot) + "_" + suffix + ".dat";
}

StatusOr<std::unordered_map<int64_t, int64_t>> ReadBarcodes(const std::string& path) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(path));
  reader->set_record_name("barcode record");
  std::unordered_map<int64_t, int64_t> subject_of_barcode;
  while (reader->Next()) {
    if (reader->fields().size() != 2) {
      return reader->Error("barcode record has " + std::to_string(reader->fields().size()) +
                           " fields; expected 2 (subject barcode)");
    }
    GS_ASSIGN_OR_RETURN(const int64_t subject, reader->Id(0, "subject"));
    GS_ASSIGN_OR_RETURN(const int64_t barcode, reader->Id(1, "barcode"));
    if (!subject_of_barcode.emplace(barcode, subject).second) {
      return reader->Error("barcode " + std::to_string(barcode) +
                           " is listed twice; expected one subject per barcode");
    }
  }
  GS_RETURN_IF_ERROR(reader->status());
  if (subject_of_barcode.empty()) {
    return Status::Corruption(reader->name() + ": has no records; expected subject barcode lines");
  }
  return subject_of_barcode;
}

// Reads "t a b c" records with non-decreasing t.
struct TimedRecords {
  std::vector<double> stamps;
  std::vector<Eigen::Vector3d> values;
  std::vector<int32_t> lines;
};

StatusOr<TimedRecords> ReadTimedRecords(const std::string& path, const char* layout) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(path));
  reader->set_record_name("record");
  TimedRecords records;
  while (reader->Next()) {
    // Odometry "t v omega" has 3 fields, ground truth "t x y theta" 4.
    const size_t expected = std::string_view(layout).find("theta") != std::string_view::npos ? 4 : 3;
    if (reader->fields().size() != expected) {
      return reader->Error("record has " + std::to_string(reader->fields().size()) +
                           " fields; expected " + std::to_string(expected) + " (" + layout + ")");
    }
    double values[4] = {0.0, 0.0, 0.0, 0.0};
    GS_ASSIGN_OR_RETURN(values[0], reader->Double(0, "time", internal::Magnitude::kTime));
    GS_RETURN_IF_ERROR(reader->Doubles(1, expected - 1, "value", values + 1));
    if (!records.stamps.empty() && values[0] < records.stamps.back()) {
      return reader->Error("time " + internal::FormatDouble(values[0]) +
                           " is earlier than the previous record's " +
                           internal::FormatDouble(records.stamps.back()) +
                           "; expected non-decreasing time stamps");
    }
    records.stamps.push_back(values[0]);
    records.values.emplace_back(values[1], values[2], values[3]);
    records.lines.push_back(reader->line_number());
  }
  GS_RETURN_IF_ERROR(reader->status());
  if (records.stamps.empty()) {
    return Status::Corruption(reader->name() + ": has no records; expected " + layout +
                              " lines");
  }
  return records;
}

// Index of the stamp nearest to t (ties: the earlier one); stamps sorted.
size_t NearestStamp(const std::vector<double>& stamps, double t) {
  const auto upper = std::lower_bound(stamps.begin(), stamps.end(), t);
  if (upper == stamps.begin()) return 0;
  if (upper == stamps.end()) return stamps.size() - 1;
  const size_t after = static_cast<size_t>(upper - stamps.begin());
  return (t - stamps[after - 1] <= stamps[after] - t) ? after - 1 : after;
}

StatusOr<std::map<int64_t, core::Point2>> ReadLandmarkGroundTruth(const std::string& path) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(path));
  reader->set_record_name("landmark record");
  std::map<int64_t, core::Point2> landmarks;
  while (reader->Next()) {
    const size_t count = reader->fields().size();
    if (count != 5 && count != 3) {
      return reader->Error("landmark record has " + std::to_string(count) +
                           " fields; expected 5 (subject x y sigma_x sigma_y) or 3");
    }
    GS_ASSIGN_OR_RETURN(const int64_t subject, reader->Id(0, "subject"));
    double values[4];
    GS_RETURN_IF_ERROR(reader->Doubles(1, count - 1, "value", values));
    if (!landmarks.emplace(subject, core::Point2(values[0], values[1])).second) {
      return reader->Error("landmark subject " + std::to_string(subject) +
                           " is listed twice; expected one record per landmark");
    }
  }
  GS_RETURN_IF_ERROR(reader->status());
  return landmarks;
}

// The information of one reading at `range` (MrclamOptions).
Eigen::Matrix2d ReadingInformation(const MrclamOptions& options, double range) {
  Eigen::Matrix2d covariance = options.measurement_information.inverse();
  const double growth = options.range_sigma_per_meter * range;
  covariance(0, 0) += growth * growth;
  return covariance.inverse();
}

}  // namespace

Status MrclamOptions::Validate() const {
  if (robot < 1 || robot > 5) {
    return Status::InvalidArgument("MrclamOptions.robot is " + std::to_string(robot) +
                                   "; expected 1..5");
  }
  for (int k = 0; k < 6; ++k) {
    if (!std::isfinite(noise.alpha[k]) || noise.alpha[k] < 0.0) {
      return Status::InvalidArgument("MrclamOptions.noise.alpha[" + std::to_string(k) + "] is " +
                                     internal::FormatDouble(noise.alpha[k]) +
                                     "; expected a finite value >= 0");
    }
  }
  if (!(noise.min_sigma_xy > 0.0) || !(noise.min_sigma_theta > 0.0) ||
      !std::isfinite(noise.min_sigma_xy) || !std::isfinite(noise.min_sigma_theta)) {
    return Status::InvalidArgument("MrclamOptions.noise.min_sigma_xy/theta are " +
                                   internal::FormatDouble(noise.min_sigma_xy) + "/" +
                                   internal::FormatDouble(noise.min_sigma_theta) +
                                   "; expected finite values > 0");
  }
  if (!(noise.noise_time_constant >= 0.0) || !std::isfinite(noise.noise_time_constant)) {
    return Status::InvalidArgument("MrclamOptions.noise.noise_time_constant is " +
                                   internal::FormatDouble(noise.noise_time_constant) +
                                   "; expected a finite number of seconds >= 0 (0: per step)");
  }
  const Eigen::Matrix2d symmetric =
      0.5 * (measurement_information + measurement_information.transpose());
  if (!internal::IsPositiveDefinite(measurement_information) ||
      (measurement_information - symmetric).cwiseAbs().maxCoeff() > 0.0) {
    return Status::InvalidArgument(
        "MrclamOptions.measurement_information is not symmetric positive definite; expected "
        "e.g. diag(1/sigma_range^2, 1/sigma_bearing^2)");
  }
  if (!(duration >= 0.0) || !std::isfinite(duration)) {
    return Status::InvalidArgument("MrclamOptions.duration is " + internal::FormatDouble(duration) +
                                   "; expected a finite number of seconds >= 0 (0: all)");
  }
  if (!(range_sigma_per_meter >= 0.0) || !std::isfinite(range_sigma_per_meter)) {
    return Status::InvalidArgument("MrclamOptions.range_sigma_per_meter is " +
                                   internal::FormatDouble(range_sigma_per_meter) +
                                   "; expected a finite value >= 0");
  }
  if (!(max_time_offset > 0.0) || !std::isfinite(max_time_offset)) {
    return Status::InvalidArgument("MrclamOptions.max_time_offset is " +
                                   internal::FormatDouble(max_time_offset) +
                                   "; expected a finite value > 0 [s]");
  }
  return Status::Ok();
}

StatusOr<MrclamGroundTruth> ReadMrclamGroundTruth(const std::string& folder, int robot) {
  MrclamGroundTruth truth;
  GS_ASSIGN_OR_RETURN(TimedRecords records,
                      ReadTimedRecords(RobotFile(folder, robot, "Groundtruth"), "t x y theta"));
  truth.stamps = std::move(records.stamps);
  truth.poses = std::move(records.values);
  GS_ASSIGN_OR_RETURN(truth.landmarks,
                      ReadLandmarkGroundTruth(folder + "/Landmark_Groundtruth.dat"));
  return truth;
}

namespace {

// "FILE:LINE: the fields" of the reader's current line, for the report.
std::string QuotedLine(const LineReader& reader) {
  std::string text = reader.name() + ":" + std::to_string(reader.line_number()) + ":";
  for (std::string_view field : reader.fields()) {
    text += ' ';
    text += field;
  }
  return text;
}

// The poses at the odometry stamps, dead-reckoned from `initial` (pose 0,
// fixed), and one velocity motion constraint per control with the
// information of options.noise.
StatusOr<core::Problem2d> DeadReckonedPoses(const std::string& folder,
                                            const std::string& odometry_path,
                                            const TimedRecords& odometry,
                                            const core::Pose2& initial,
                                            const MrclamOptions& options) {
  core::Problem2d problem;
  problem.source = folder;
  const size_t count = odometry.stamps.size();
  problem.AddPose(0, initial, /*initialized=*/true, odometry.lines[0], odometry.stamps[0]);
  problem.pose_fixed[0] = 1;
  core::Pose2 dead_reckoned = initial;
  for (size_t k = 0; k + 1 < count; ++k) {
    core::VelocityControl control;
    control.v = odometry.values[k].x();
    control.omega = odometry.values[k].y();
    control.dt = odometry.stamps[k + 1] - odometry.stamps[k];
    const Eigen::Matrix3d covariance =
        core::VelocityMotionCovariance(dead_reckoned, control, options.noise);
    const Eigen::Matrix3d information = covariance.inverse();
    if (!internal::IsPositiveDefinite(information)) {
      return Status::Numerical(internal::BaseName(odometry_path) + ":" +
                               std::to_string(odometry.lines[k]) +
                               ": motion information (inverse of the velocity motion "
                               "covariance) is not positive definite; expected the noise floor "
                               "min_sigma_xy/theta to keep it definite");
    }
    dead_reckoned = core::PredictVelocityMotion(dead_reckoned, control);
    const int32_t to = problem.AddPose(static_cast<int64_t>(k + 1), dead_reckoned,
                                       /*initialized=*/false, odometry.lines[k + 1],
                                       odometry.stamps[k + 1]);
    core::VelocityMotionConstraint motion;
    motion.from = to - 1;
    motion.to = to;
    motion.control = control;
    motion.information = information;
    motion.line = odometry.lines[k];
    problem.motions.push_back(motion);
  }
  return problem;
}

// One record of RobotN_Measurement.dat: "t barcode range bearing".
struct Reading {
  double t = 0;
  int64_t barcode = 0;
  double range = 0;
  double bearing = 0;
};

StatusOr<Reading> ParseReading(const LineReader& reader) {
  if (reader.fields().size() != 4) {
    return reader.Error("measurement has " + std::to_string(reader.fields().size()) +
                        " fields; expected 4 (t barcode range bearing)");
  }
  Reading reading;
  GS_ASSIGN_OR_RETURN(reading.t, reader.Double(0, "time", internal::Magnitude::kTime));
  GS_ASSIGN_OR_RETURN(reading.barcode, reader.Id(1, "barcode"));
  GS_ASSIGN_OR_RETURN(reading.range, reader.Double(2, "range"));
  GS_ASSIGN_OR_RETURN(reading.bearing, reader.Double(3, "bearing"));
  return reading;
}

// A reading of another robot (subject 1..5): kept beside the problem.
MrclamRobotSighting RobotSighting(const Reading& reading, int64_t subject,
                                  const MrclamOptions& options, int32_t line) {
  MrclamRobotSighting sighting;
  sighting.stamp = reading.t;
  sighting.observed_robot = static_cast<int>(subject);
  sighting.z = Eigen::Vector2d(reading.range, reading.bearing);
  sighting.information = ReadingInformation(options, reading.range);
  sighting.line = line;
  return sighting;
}

// Robot `options.robot`'s odometry, cut to its first options.duration
// seconds when that is set (later measurements then have no pose).
StatusOr<TimedRecords> ReadOdometry(const std::string& path, const MrclamOptions& options) {
  GS_ASSIGN_OR_RETURN(TimedRecords odometry, ReadTimedRecords(path, "t v omega"));
  if (options.duration > 0.0 && !odometry.stamps.empty()) {
    const auto kept = static_cast<size_t>(
        std::upper_bound(odometry.stamps.begin(), odometry.stamps.end(),
                         odometry.stamps.front() + options.duration) - odometry.stamps.begin());
    odometry.stamps.resize(kept);
    odometry.values.resize(kept);
    odometry.lines.resize(kept);
  }
  return odometry;
}

// moving_before[k]: controls 0..k-1 that move the robot (MrclamStandsStill);
// poses p, q stand still together iff moving_before[p] == moving_before[q].
std::vector<int64_t> MovingBefore(const TimedRecords& odometry) {
  std::vector<int64_t> moving_before(odometry.stamps.size(), 0);
  for (size_t k = 1; k < moving_before.size(); ++k) {
    const Eigen::Vector3d& control = odometry.values[k - 1];
    moving_before[k] = moving_before[k - 1] + (MrclamStandsStill(control.x(), control.y()) ? 0 : 1);
  }
  return moving_before;
}

// Repeats of one landmark reading while the robot stands still (no moving
// control between their poses), merged into the first: per observation the sums of (range, cos bearing, sin bearing)
// and the count of readings merged in.
class StandstillRepeats {
 public:
  // Observation `index` (the next one) of `feature` at standstill `still`
  // when `merge`; returns false when the reading joins an earlier one.
  bool Add(bool merge, int32_t feature, int64_t still, size_t index, double range,
           double bearing) {
    const Eigen::Vector3d reading(range, std::cos(bearing), std::sin(bearing));
    if (merge) {
      const auto [group, inserted] = group_.try_emplace({feature, still}, index);
      if (!inserted) {
        sums_[group->second] += reading;
        ++counts_[group->second];
        return false;
      }
    }
    sums_.push_back(reading);
    counts_.push_back(1);
    return true;
  }

  // A merged observation is the mean of its repeats (circular mean of the
  // bearing) with the information of one measurement: the repeats' errors
  // are the same error seen again, so they add no information.
  void Average(const MrclamOptions& options, std::vector<core::Observation>* observations) const {
    for (size_t i = 0; i < observations->size(); ++i) {
      if (counts_[i] < 2) continue;
      core::Observation& observation = (*observations)[i];
      const Eigen::Vector3d& sum = sums_[i];
      observation.z = Eigen::Vector2d(sum.x() / counts_[i], std::atan2(sum.z(), sum.y()));
      observation.information = ReadingInformation(options, observation.z.x());
    }
  }

 private:
  std::map<std::pair<int32_t, int64_t>, size_t> group_;  // (feature, standstill) -> observation
  std::vector<Eigen::Vector3d> sums_;
  std::vector<int32_t> counts_;
};

// The feature a landmark reading of `subject` observes: a new one per
// reading with options.ignore_barcodes (unknown correspondence: the barcode
// only tells a landmark from a robot, robots carry barcodes too), else the
// subject's.
int32_t FeatureOfSubject(int64_t subject, const MrclamOptions& options,
                         std::unordered_map<int64_t, int32_t>* feature_of_subject,
                         core::Problem2d* problem) {
  if (options.ignore_barcodes)
    return problem->AddFeature(core::kNoFeatureId, core::Point2::Zero(), /*initialized=*/false);
  const auto [feature, inserted] =
      feature_of_subject->try_emplace(subject, problem->num_features());
  if (inserted) problem->AddFeature(subject, core::Point2::Zero(), /*initialized=*/false);
  return feature->second;
}

void LogReadStats(const std::string& folder, const std::string& measurements, int robot,
                  const MrclamReadStats& stats) {
  if (stats.unknown_barcodes_skipped > 0) {
    GS_LOG(WARNING, "%s: %lld measurements have a barcode that is in no row of Barcodes.dat "
           "(first: %s); skipped", measurements.c_str(),
           static_cast<long long>(stats.unknown_barcodes_skipped),
           stats.unknown_barcode_lines.front().c_str());
  }
  GS_VLOG(1, "%s robot %d: %lld poses, %lld landmark observations, %lld robot measurements "
          "dropped, %lld out of time range",
          folder.c_str(), robot, static_cast<long long>(stats.odometry_records),
          static_cast<long long>(stats.landmark_observations),
          static_cast<long long>(stats.robot_measurements_dropped),
          static_cast<long long>(stats.out_of_time_range_dropped));
}

}  // namespace

StatusOr<core::Problem2d> ReadMrclam(const std::string& folder, const MrclamOptions& options,
                                     MrclamReadStats* stats) {
  GS_RETURN_IF_ERROR(options.Validate());
  std::error_code error;
  if (!std::filesystem::is_directory(folder, error)) {
    return Status::NotFound(folder + ": is not a directory; expected an MRCLAM dataset folder");
  }
  MrclamReadStats local_stats;
  GS_ASSIGN_OR_RETURN(const auto subject_of_barcode, ReadBarcodes(folder + "/Barcodes.dat"));
  const std::string odometry_path = RobotFile(folder, options.robot, "Odometry");
  GS_ASSIGN_OR_RETURN(const TimedRecords odometry, ReadOdometry(odometry_path, options));
  local_stats.odometry_records = static_cast<int64_t>(odometry.stamps.size());

  // The anchor: ground truth nearest to t_0 if present, else the origin.
  core::Pose2 initial = core::Pose2::Zero();
  const std::string truth_path = RobotFile(folder, options.robot, "Groundtruth");
  if (options.start_at_ground_truth && std::filesystem::exists(truth_path, error)) {
    GS_ASSIGN_OR_RETURN(const TimedRecords truth, ReadTimedRecords(truth_path, "t x y theta"));
    initial = truth.values[NearestStamp(truth.stamps, odometry.stamps[0])];
  }

  GS_ASSIGN_OR_RETURN(core::Problem2d problem,
                      DeadReckonedPoses(folder, odometry_path, odometry, initial, options));
  const std::string measurement_path = RobotFile(folder, options.robot, "Measurement");
  GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(measurement_path));
  reader->set_record_name("measurement");
  std::unordered_map<int64_t, int32_t> feature_of_subject;
  const std::vector<int64_t> moving_before = MovingBefore(odometry);
  const bool merge = options.merge_standstill_repeats && !options.ignore_barcodes;
  StandstillRepeats repeats;
  while (reader->Next()) {
    GS_ASSIGN_OR_RETURN(const Reading reading, ParseReading(*reader));
    const auto [t, barcode, range, bearing] = reading;
    ++local_stats.measurements;
    const auto subject = subject_of_barcode.find(barcode);
    if (subject == subject_of_barcode.end()) {
      // A misread barcode of the published data: skipped, not fatal.
      if (local_stats.unknown_barcode_lines.size() < MrclamReadStats::kMaxUnknownBarcodeLines)
        local_stats.unknown_barcode_lines.push_back(QuotedLine(*reader));
      ++local_stats.unknown_barcodes_skipped;
      continue;
    }
    if (!(range > 0.0)) {
      return reader->Error("range " + internal::FormatDouble(range) + "; expected range > 0");
    }
    if (subject->second <= kLastRobotSubject) {
      ++local_stats.robot_measurements_dropped;
      local_stats.robot_sightings.push_back(
          RobotSighting(reading, subject->second, options, reader->line_number()));
      continue;
    }
    const size_t pose = NearestStamp(odometry.stamps, t);
    if (std::abs(odometry.stamps[pose] - t) > options.max_time_offset) {
      ++local_stats.out_of_time_range_dropped;
      continue;
    }
    const int32_t feature =
        FeatureOfSubject(subject->second, options, &feature_of_subject, &problem);
    if (!repeats.Add(merge, feature, moving_before[pose], problem.observations.size(), range,
                     bearing)) {
      ++local_stats.standstill_repeats_merged;
      continue;
    }
    core::Observation observation;
    observation.pose = static_cast<int32_t>(pose);
    observation.feature = feature;
    observation.kind = core::ObservationKind::kRangeBearing;
    observation.z = Eigen::Vector2d(range, bearing);
    observation.information = ReadingInformation(options, range);
    observation.line = reader->line_number();
    problem.observations.push_back(observation);
    ++local_stats.landmark_observations;
  }
  GS_RETURN_IF_ERROR(reader->status());
  repeats.Average(options, &problem.observations);
  LogReadStats(folder, reader->name(), options.robot, local_stats);
  if (stats != nullptr) *stats = local_stats;
  return problem;
}

}  // namespace graphslam::storage
