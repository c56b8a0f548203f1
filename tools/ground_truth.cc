#include "tools/ground_truth.h"

#include "storage/kitti_pose_reader.h"
#include "storage/trajectory_format.h"

namespace graphslam::tools {

StatusOr<std::vector<StampedPose2>> ReadGroundTruth(const GroundTruthFile& file) {
  StatusOr<storage::TrajectoryFormat> format = file.format == "auto"
                                                   ? storage::DetectTrajectoryFormat(file.path)
                                                   : storage::ParseTrajectoryFormat(file.format);
  if (!format.ok()) return format.status();
  GS_ASSIGN_OR_RETURN(std::vector<storage::StampedPose3> poses,
                      storage::ReadTrajectory(file.path, *format, file.times));
  std::vector<StampedPose2> planar;
  planar.reserve(poses.size());
  for (const storage::StampedPose3& pose : poses) {
    const storage::StampedPose3 body =
        *format == storage::TrajectoryFormat::kKitti ? storage::KittiCameraToBody(pose) : pose;
    planar.push_back(StampedPose2{body.stamp, storage::ProjectToPlane(body)});
  }
  return planar;
}

}  // namespace graphslam::tools
