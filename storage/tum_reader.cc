#include "storage/tum_reader.h"

#include <memory>

#include "storage/internal/text_reader.h"

namespace graphslam::storage {

StatusOr<std::vector<StampedPose3>> ReadTumTrajectory(const std::string& path) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  reader->set_record_name("TUM pose");
  std::vector<StampedPose3> poses;
  while (reader->Next()) {
    if (reader->fields().size() != 8) {
      return reader->Error("TUM pose has " + std::to_string(reader->fields().size()) +
                           " fields; expected 8 (t x y z qx qy qz qw)");
    }
    double v[8];
    GS_ASSIGN_OR_RETURN(v[0], reader->Double(0, "t", internal::Magnitude::kTime));
    GS_RETURN_IF_ERROR(reader->Doubles(1, 3, "position", v + 1));
    GS_RETURN_IF_ERROR(reader->Doubles(4, 4, "quaternion", v + 4));
    StampedPose3 pose;
    pose.stamp = v[0];
    pose.position = Eigen::Vector3d(v[1], v[2], v[3]);
    pose.orientation = Eigen::Quaterniond(v[7], v[4], v[5], v[6]);
    const double norm = pose.orientation.norm();
    if (!(norm > 1e-9)) {
      return reader->Error("quaternion (qx qy qz qw) has norm " + internal::FormatDouble(norm) +
                           "; expected a unit quaternion");
    }
    pose.orientation.normalize();
    poses.push_back(pose);
  }
  GS_RETURN_IF_ERROR(reader->status());
  return poses;
}

}  // namespace graphslam::storage
