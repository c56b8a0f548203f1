#include "tools/trajectory_metrics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <sstream>
#include <limits>
#include <string_view>
#include <utility>

#include "core/angle.h"
#include "core/check.h"
#include "storage/env.h"
#include "storage/tum_reader.h"

namespace graphslam::tools {
namespace {

std::string_view Trim(std::string_view text) {
  while (!text.empty() && (text.front() == ' ' || text.front() == '\t')) text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\t' || text.back() == '\r'))
    text.remove_suffix(1);
  return text;
}

std::vector<std::string_view> SplitCommas(std::string_view line) {
  std::vector<std::string_view> fields;
  size_t start = 0;
  while (true) {
    const size_t comma = line.find(',', start);
    if (comma == std::string_view::npos) {
      fields.push_back(Trim(line.substr(start)));
      return fields;
    }
    fields.push_back(Trim(line.substr(start, comma - start)));
    start = comma + 1;
  }
}

bool ParseDouble(std::string_view text, double* value) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const auto result = std::from_chars(text.data(), text.data() + text.size(), *value);
  return result.ec == std::errc() && result.ptr == text.data() + text.size() &&
         std::isfinite(*value);
}

bool ParseInt(std::string_view text, int64_t* value) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const auto result = std::from_chars(text.data(), text.data() + text.size(), *value);
  return result.ec == std::errc() && result.ptr == text.data() + text.size();
}

std::string Where(const std::string& path, int64_t line) {
  return path + ":" + std::to_string(line) + ": ";
}

// [begin, end) of each run: a stamp below its predecessor starts a new one.
std::vector<std::pair<size_t, size_t>> SplitRuns(const std::vector<StampedPose2>& poses) {
  std::vector<std::pair<size_t, size_t>> runs;
  size_t begin = 0;
  for (size_t i = 1; i <= poses.size(); ++i) {
    if (i == poses.size() || poses[i].stamp < poses[i - 1].stamp) {
      runs.emplace_back(begin, i);
      begin = i;
    }
  }
  return runs;
}

double MedianSpacing(const std::vector<StampedPose2>& poses,
                     const std::vector<std::pair<size_t, size_t>>& runs) {
  std::vector<double> spacing;
  for (const auto& [begin, end] : runs) {
    for (size_t i = begin + 1; i < end; ++i) spacing.push_back(poses[i].stamp - poses[i - 1].stamp);
  }
  if (spacing.empty()) return std::numeric_limits<double>::infinity();
  const size_t middle = spacing.size() / 2;
  std::nth_element(spacing.begin(), spacing.begin() + static_cast<std::ptrdiff_t>(middle),
                   spacing.end());
  return spacing[middle];
}

}  // namespace

StatusOr<std::vector<StampedPose2>> ReadTum(const std::string& path) {
  GS_ASSIGN_OR_RETURN(std::vector<storage::StampedPose3> poses, storage::ReadTumTrajectory(path));
  std::vector<StampedPose2> planar;
  planar.reserve(poses.size());
  for (const storage::StampedPose3& pose : poses)
    planar.push_back(StampedPose2{pose.stamp, storage::ProjectToPlane(pose)});
  return planar;
}

StatusOr<std::map<int64_t, core::Point2>> ReadFeaturesCsv(const std::string& path,
                                                          std::vector<int64_t>* excluded_ids) {
  GS_ASSIGN_OR_RETURN(const std::string text,
                      storage::ReadFileToString(storage::Env::Default(), path,
                                                path + ": no such file"));
  std::istringstream in(text);
  std::map<int64_t, core::Point2> features;
  std::map<int64_t, int64_t> first_line;  // id -> line, for duplicate messages
  if (excluded_ids != nullptr) excluded_ids->clear();
  std::string line;
  int64_t line_number = 0;
  bool first_row = true;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string_view trimmed = Trim(line);
    if (trimmed.empty() || trimmed.front() == '#') continue;
    const std::vector<std::string_view> fields = SplitCommas(trimmed);
    if (first_row && fields[0] == "id") {  // the header
      first_row = false;
      continue;
    }
    first_row = false;
    if (fields.size() < 3) {
      return Status::Corruption(Where(path, line_number) +
                                "expected at least 3 fields 'id,x,y[,observations,excluded]', got " +
                                std::to_string(fields.size()));
    }
    int64_t id = 0;
    if (!ParseInt(fields[0], &id)) {
      return Status::Corruption(Where(path, line_number) + "id: expected an integer, got '" +
                                std::string(fields[0]) + "'");
    }
    core::Point2 position;
    for (int i = 0; i < 2; ++i) {
      if (!ParseDouble(fields[static_cast<size_t>(i) + 1], &position[i])) {
        return Status::Corruption(Where(path, line_number) + (i == 0 ? "x" : "y") +
                                  ": expected a finite number, got '" +
                                  std::string(fields[static_cast<size_t>(i) + 1]) + "'");
      }
    }
    bool excluded = false;
    if (fields.size() >= 5) {
      int64_t flag = 0;
      if (!ParseInt(fields[4], &flag) || (flag != 0 && flag != 1)) {
        return Status::Corruption(Where(path, line_number) + "excluded: expected 0 or 1, got '" +
                                  std::string(fields[4]) + "'");
      }
      excluded = flag == 1;
    }
    const auto [it, inserted] = first_line.emplace(id, line_number);
    if (!inserted) {
      return Status::Corruption(Where(path, line_number) + "duplicate feature id " +
                                std::to_string(id) + " (first on line " +
                                std::to_string(it->second) + ")");
    }
    if (excluded) {
      if (excluded_ids != nullptr) excluded_ids->push_back(id);
      continue;
    }
    features.emplace(id, position);
  }
  if (in.bad()) return Status::IOError(path + ": read error after line " + std::to_string(line_number));
  return features;
}

Eigen::Isometry2d AlignRigid(const std::vector<core::Point2>& source,
                             const std::vector<core::Point2>& target) {
  GS_CHECK(source.size() == target.size());
  Eigen::Isometry2d transform = Eigen::Isometry2d::Identity();
  const size_t n = source.size();
  if (n == 0) return transform;
  if (n == 1) {
    transform.translation() = target[0] - source[0];
    return transform;
  }
  Eigen::MatrixXd from(2, static_cast<Eigen::Index>(n));
  Eigen::MatrixXd to(2, static_cast<Eigen::Index>(n));
  for (size_t i = 0; i < n; ++i) {
    from.col(static_cast<Eigen::Index>(i)) = source[i];
    to.col(static_cast<Eigen::Index>(i)) = target[i];
  }
  const Eigen::Matrix3d homogeneous = Eigen::umeyama(from, to, /*with_scaling=*/false);
  transform.linear() = homogeneous.topLeftCorner<2, 2>();
  transform.translation() = homogeneous.topRightCorner<2, 1>();
  return transform;
}

double RotationAngle(const Eigen::Isometry2d& transform) {
  return std::atan2(transform.linear()(1, 0), transform.linear()(0, 0));
}

StatusOr<TrajectoryErrors> CompareTrajectories(const std::vector<StampedPose2>& estimated,
                                               const std::vector<StampedPose2>& ground_truth,
                                               const TrajectoryMatchOptions& options) {
  if (ground_truth.empty()) return Status::InvalidArgument("the ground-truth trajectory is empty");
  if (estimated.empty()) return Status::InvalidArgument("the estimated trajectory is empty");
  const std::vector<std::pair<size_t, size_t>> estimated_runs = SplitRuns(estimated);
  const std::vector<std::pair<size_t, size_t>> truth_runs = SplitRuns(ground_truth);
  if (estimated_runs.size() != truth_runs.size()) {
    return Status::InvalidArgument(
        "the estimate holds " + std::to_string(estimated_runs.size()) +
        " runs but the ground truth " + std::to_string(truth_runs.size()) +
        " (a time stamp smaller than its predecessor starts a new run)");
  }
  TrajectoryErrors errors;
  errors.runs = static_cast<int64_t>(estimated_runs.size());
  errors.max_time_difference = options.max_time_difference >= 0.0
                                   ? options.max_time_difference
                                   : std::min(0.05, 0.5 * MedianSpacing(ground_truth, truth_runs));

  std::vector<core::Point2> from, to;
  for (size_t run = 0; run < estimated_runs.size(); ++run) {
    const auto truth_begin = ground_truth.begin() + static_cast<std::ptrdiff_t>(truth_runs[run].first);
    const auto truth_end = ground_truth.begin() + static_cast<std::ptrdiff_t>(truth_runs[run].second);
    for (size_t i = estimated_runs[run].first; i < estimated_runs[run].second; ++i) {
      const double stamp = estimated[i].stamp;
      auto it = std::lower_bound(truth_begin, truth_end, stamp,
                                 [](const StampedPose2& pose, double t) { return pose.stamp < t; });
      auto best = truth_end;
      double best_difference = std::numeric_limits<double>::infinity();
      if (it != truth_end) {
        best = it;
        best_difference = it->stamp - stamp;
      }
      if (it != truth_begin && stamp - std::prev(it)->stamp <= best_difference) {
        best = std::prev(it);
        best_difference = stamp - best->stamp;
      }
      if (best == truth_end || best_difference > errors.max_time_difference) {
        ++errors.unmatched;
        continue;
      }
      errors.estimated_index.push_back(static_cast<int64_t>(i));
      errors.ground_truth_index.push_back(static_cast<int64_t>(best - ground_truth.begin()));
      from.push_back(estimated[i].pose.head<2>());
      to.push_back(best->pose.head<2>());
    }
  }
  errors.matched = static_cast<int64_t>(from.size());
  if (errors.matched == 0) {
    return Status::InvalidArgument(
        "no estimated pose has a ground-truth pose within " +
        std::to_string(errors.max_time_difference) + " s (estimate " +
        std::to_string(estimated.front().stamp) + ".." + std::to_string(estimated.back().stamp) +
        " s, ground truth " + std::to_string(ground_truth.front().stamp) + ".." +
        std::to_string(ground_truth.back().stamp) + " s)");
  }
  if (options.align) errors.alignment = AlignRigid(from, to);
  const double rotation = RotationAngle(errors.alignment);
  double position_sum = 0.0, heading_sum = 0.0, distance_sum = 0.0;
  for (size_t k = 0; k < from.size(); ++k) {
    const double distance = (errors.alignment * from[k] - to[k]).norm();
    position_sum += distance * distance;
    distance_sum += distance;
    errors.position_max = std::max(errors.position_max, distance);
    const double heading_error = core::WrapAngle(
        estimated[static_cast<size_t>(errors.estimated_index[k])].pose.z() + rotation -
        ground_truth[static_cast<size_t>(errors.ground_truth_index[k])].pose.z());
    heading_sum += heading_error * heading_error;
  }
  const double n = static_cast<double>(from.size());
  errors.position_rmse = std::sqrt(position_sum / n);
  errors.heading_rmse_rad = std::sqrt(heading_sum / n);
  errors.position_mean = distance_sum / n;
  return errors;
}

StatusOr<JointTrajectoryErrors> CompareTrajectoriesJointly(
    const std::vector<std::vector<StampedPose2>>& estimated,
    const std::vector<std::vector<StampedPose2>>& ground_truth,
    const TrajectoryMatchOptions& options) {
  if (estimated.size() != ground_truth.size())
    return Status::InvalidArgument(std::to_string(estimated.size()) + " estimated runs but " +
                                   std::to_string(ground_truth.size()) + " ground truths");
  // Matching per run (its own alignment only decides nothing here).
  std::vector<core::Point2> from, to;
  for (size_t r = 0; r < estimated.size(); ++r) {
    StatusOr<TrajectoryErrors> own = CompareTrajectories(estimated[r], ground_truth[r], options);
    if (!own.ok()) return own.status().WithContext("run " + std::to_string(r));
    for (size_t k = 0; k < own->estimated_index.size(); ++k) {
      from.push_back(estimated[r][static_cast<size_t>(own->estimated_index[k])].pose.head<2>());
      to.push_back(ground_truth[r][static_cast<size_t>(own->ground_truth_index[k])].pose.head<2>());
    }
  }
  JointTrajectoryErrors joint;
  if (options.align) joint.alignment = AlignRigid(from, to);
  const double rotation = RotationAngle(joint.alignment);
  TrajectoryMatchOptions in_truth_frame = options;
  in_truth_frame.align = false;
  double position_sum = 0.0, heading_sum = 0.0;
  for (size_t r = 0; r < estimated.size(); ++r) {
    std::vector<StampedPose2> moved = estimated[r];
    for (StampedPose2& pose : moved) {
      pose.pose.head<2>() = joint.alignment * pose.pose.head<2>();
      pose.pose.z() = core::WrapAngle(pose.pose.z() + rotation);
    }
    StatusOr<TrajectoryErrors> errors = CompareTrajectories(moved, ground_truth[r], in_truth_frame);
    if (!errors.ok()) return errors.status().WithContext("run " + std::to_string(r));
    errors->alignment = joint.alignment;
    const double n = static_cast<double>(errors->matched);
    position_sum += errors->position_rmse * errors->position_rmse * n;
    heading_sum += errors->heading_rmse_rad * errors->heading_rmse_rad * n;
    joint.matched += errors->matched;
    joint.runs.push_back(std::move(errors).value());
  }
  if (joint.matched > 0) {
    joint.position_rmse = std::sqrt(position_sum / static_cast<double>(joint.matched));
    joint.heading_rmse_rad = std::sqrt(heading_sum / static_cast<double>(joint.matched));
  }
  return joint;
}

double FeatureRmse(const std::map<int64_t, core::Point2>& estimated,
                   const std::map<int64_t, core::Point2>& ground_truth,
                   const Eigen::Isometry2d& estimated_to_ground_truth, int64_t* matched) {
  double sum = 0.0;
  int64_t count = 0;
  for (const auto& [id, position] : estimated) {
    const auto it = ground_truth.find(id);
    if (it == ground_truth.end()) continue;
    sum += (estimated_to_ground_truth * position - it->second).squaredNorm();
    ++count;
  }
  if (matched != nullptr) *matched = count;
  if (count == 0) return std::numeric_limits<double>::quiet_NaN();
  return std::sqrt(sum / static_cast<double>(count));
}

FeatureErrors CompareFeatures(const std::map<int64_t, core::Point2>& estimated,
                              const std::map<int64_t, core::Point2>& ground_truth,
                              const Eigen::Isometry2d& trajectory_alignment) {
  FeatureErrors errors;
  std::vector<core::Point2> from, to;
  for (const auto& [id, position] : estimated) {
    const auto it = ground_truth.find(id);
    if (it == ground_truth.end()) {
      ++errors.extra;
      continue;
    }
    from.push_back(position);
    to.push_back(it->second);
  }
  errors.matched = static_cast<int64_t>(from.size());
  errors.missing = static_cast<int64_t>(ground_truth.size()) - errors.matched;
  errors.rmse_trajectory_aligned = FeatureRmse(estimated, ground_truth, trajectory_alignment);
  errors.self_alignment = AlignRigid(from, to);
  errors.rmse_self_aligned = FeatureRmse(estimated, ground_truth, errors.self_alignment);
  return errors;
}

}  // namespace graphslam::tools
