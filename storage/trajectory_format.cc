#include "storage/trajectory_format.h"

#include <memory>

#include "storage/internal/text_reader.h"
#include "storage/kitti_pose_reader.h"
#include "storage/tum_reader.h"

namespace graphslam::storage {

StatusOr<TrajectoryFormat> ParseTrajectoryFormat(std::string_view name) {
  if (name == "tum") return TrajectoryFormat::kTum;
  if (name == "kitti") return TrajectoryFormat::kKitti;
  return Status::InvalidArgument("trajectory format '" + std::string(name) +
                                 "'; expected auto, tum or kitti");
}

StatusOr<TrajectoryFormat> DetectTrajectoryFormat(const std::string& path) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  if (!reader->Next()) {
    GS_RETURN_IF_ERROR(reader->status());
    return Status::Corruption(internal::BaseName(path) +
                              ": has no pose; expected a TUM or KITTI trajectory");
  }
  const size_t fields = reader->fields().size();
  if (fields == 8) return TrajectoryFormat::kTum;
  if (fields == 12) return TrajectoryFormat::kKitti;
  return reader->Error("trajectory line has " + std::to_string(fields) +
                       " fields; expected 8 (TUM) or 12 (KITTI)");
}

StatusOr<std::vector<StampedPose3>> ReadTrajectory(const std::string& path,
                                                   TrajectoryFormat format,
                                                   const std::string& kitti_times) {
  if (format == TrajectoryFormat::kKitti) return ReadKittiPoses(path, kitti_times);
  if (!kitti_times.empty()) {
    return Status::InvalidArgument(kitti_times + ": a times file goes with KITTI poses only; " +
                                   path + " is TUM, which carries its own times");
  }
  return ReadTumTrajectory(path);
}

}  // namespace graphslam::storage
