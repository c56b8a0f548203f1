#include "storage/kitti_pose_reader.h"

#include <Eigen/Dense>
#include <memory>

#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

// The published files print 6-9 significant digits: their rotations are
// orthonormal to ~1e-6; 1e-3 rejects matrices that are no rotation at all.
constexpr double kRotationTolerance = 1e-3;

StatusOr<std::vector<double>> ReadTimes(const std::string& path) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  reader->set_record_name("time");
  std::vector<double> times;
  while (reader->Next()) {
    if (reader->fields().size() != 1) {
      return reader->Error("time line has " + std::to_string(reader->fields().size()) +
                           " fields; expected 1 (time in seconds)");
    }
    GS_ASSIGN_OR_RETURN(const double t, reader->Double(0, "t", internal::Magnitude::kTime));
    if (!times.empty() && t < times.back()) {
      return reader->Error("time " + internal::FormatDouble(t) + " is below the previous one, " +
                           internal::FormatDouble(times.back()) + "; expected non-decreasing times");
    }
    times.push_back(t);
  }
  GS_RETURN_IF_ERROR(reader->status());
  return times;
}

}  // namespace

StatusOr<std::vector<StampedPose3>> ReadKittiPoses(const std::string& path,
                                                   const std::string& times_path) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  reader->set_record_name("KITTI pose");
  std::vector<StampedPose3> poses;
  while (reader->Next()) {
    if (reader->fields().size() != 12) {
      return reader->Error("KITTI pose has " + std::to_string(reader->fields().size()) +
                           " fields; expected 12 (the 3x4 matrix [R | t] row by row)");
    }
    double v[12];
    GS_RETURN_IF_ERROR(reader->Doubles(0, 12, "matrix", v));
    Eigen::Matrix3d rotation;
    rotation << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    const double off = (rotation.transpose() * rotation - Eigen::Matrix3d::Identity())
                           .cwiseAbs()
                           .maxCoeff();
    const double det = rotation.determinant();
    if (!(off <= kRotationTolerance) || !(det > 0.0)) {
      return reader->Error("rotation block has max |R^T R - I| = " + internal::FormatDouble(off) +
                           " and det " + internal::FormatDouble(det) +
                           "; expected a rotation (max |R^T R - I| <= 1e-3, det > 0)");
    }
    StampedPose3 pose;
    pose.stamp = static_cast<double>(poses.size());
    pose.position = Eigen::Vector3d(v[3], v[7], v[11]);
    pose.orientation = Eigen::Quaterniond(rotation).normalized();
    poses.push_back(pose);
  }
  GS_RETURN_IF_ERROR(reader->status());
  if (times_path.empty()) return poses;
  GS_ASSIGN_OR_RETURN(const std::vector<double> times, ReadTimes(times_path));
  if (times.size() != poses.size()) {
    return Status::Corruption(internal::BaseName(times_path) + ": " +
                              std::to_string(times.size()) + " times for " +
                              std::to_string(poses.size()) + " poses in " +
                              internal::BaseName(path) + "; expected one time per pose");
  }
  for (size_t i = 0; i < poses.size(); ++i) poses[i].stamp = times[i];
  return poses;
}

StampedPose3 KittiCameraToBody(const StampedPose3& camera) {
  Eigen::Matrix3d c;
  c << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  StampedPose3 body = camera;
  body.position = c * camera.position;
  body.orientation =
      Eigen::Quaterniond(c * camera.orientation.toRotationMatrix() * c.transpose()).normalized();
  return body;
}

}  // namespace graphslam::storage
