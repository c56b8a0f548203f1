#include "storage/native_log_scans.h"

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "storage/pcd_io.h"

namespace graphslam::map {
namespace {

std::string Where(const std::string& log_name, int32_t line) {
  return log_name + ":" + std::to_string(line) + ": ";
}

}  // namespace

bool IsNativeLogFile(const std::string& path) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error)) return false;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string first;
    if (!(fields >> first) || first[0] == '#') continue;
    return first == storage::kNativeLogMagic;
  }
  return false;
}

core::Pose3 LiftLoggedPose(const core::Pose2& p) {
  core::Pose3 pose;
  pose.t = Eigen::Vector3d(p.x(), p.y(), 0.0);
  pose.q = Eigen::Quaterniond(Eigen::AngleAxisd(p.z(), Eigen::Vector3d::UnitZ()));
  return pose;
}

StatusOr<std::unique_ptr<NativeLogScanSource>> NativeLogScanSource::Open(
    const std::string& log_path) {
  std::vector<storage::NativeLogScan> records;
  GS_ASSIGN_OR_RETURN(core::Problem2d problem, storage::ReadNativeLog(log_path, &records));
  if (records.empty())
    return Status::InvalidArgument(std::filesystem::path(log_path).filename().string() +
                                   ": has no SCAN records; expected SCAN pose file.pcd lines");
  std::vector<core::Pose3> poses;
  poses.reserve(records.size());
  for (const storage::NativeLogScan& record : records)
    poses.push_back(LiftLoggedPose(problem.poses[static_cast<size_t>(record.pose)]));
  return FromRecords(log_path, std::move(records), std::move(poses));
}

StatusOr<std::unique_ptr<NativeLogScanSource>> NativeLogScanSource::FromRecords(
    const std::string& log_path, std::vector<storage::NativeLogScan> records,
    std::vector<core::Pose3> record_poses) {
  GS_CHECK(records.size() == record_poses.size());
  std::unique_ptr<NativeLogScanSource> source(new NativeLogScanSource());
  const std::filesystem::path log(log_path);
  source->log_name_ = log.filename().string();
  source->records_ = std::move(records);
  source->poses_ = std::move(record_poses);
  for (const storage::NativeLogScan& record : source->records_) {
    const std::filesystem::path file(record.file);
    const std::filesystem::path resolved = file.is_absolute() ? file : log.parent_path() / file;
    std::error_code error;
    if (!std::filesystem::is_regular_file(resolved, error)) {
      return Status::NotFound(Where(source->log_name_, record.line) + "SCAN file '" +
                              record.file + "' (" + resolved.string() +
                              ") does not exist; expected a .pcd file, relative to the log's "
                              "folder unless absolute");
    }
    source->resolved_.push_back(resolved.string());
  }
  return source;
}

Status NativeLogScanSource::Load(int64_t index, std::vector<Scan>* scans) const {
  if (index < 0 || index >= NumChunks())
    return Status::InvalidArgument("scan chunk " + std::to_string(index) + " out of range");
  const storage::NativeLogScan& record = records_[static_cast<size_t>(index)];
  const std::string& path = resolved_[static_cast<size_t>(index)];
  StatusOr<PcdContents> read = ReadPcd(path);
  if (!read.ok()) {
    return Status::Corruption(Where(log_name_, record.line) + "SCAN file '" + record.file +
                              "' cannot be read (" + read.status().message() +
                              "); expected a PCD file with float x y z fields");
  }
  Scan scan;
  scan.pose = record.pose;
  scan.sensor_pose = poses_[static_cast<size_t>(index)];
  const bool intensity = !read->intensity.empty();
  for (size_t i = 0; i < read->points.size(); ++i) {
    if (!read->points[i].allFinite()) continue;  // organized clouds mark holes with NaN
    scan.points.push_back(read->points[i]);
    if (intensity) scan.intensity.push_back(read->intensity[i]);
  }
  scans->clear();
  scans->push_back(std::move(scan));
  return Status::Ok();
}

}  // namespace graphslam::map
