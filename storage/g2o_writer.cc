#include "storage/g2o_writer.h"

#include <Eigen/LU>
#include <algorithm>
#include <limits>
#include <vector>

#include "core/se2.h"
#include "core/velocity_motion_model.h"
#include "storage/atomic_file.h"
#include "storage/internal/problem_validation.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::FormatDouble;

// See g2o_writer.h: polar -> cartesian with first-order information.
void RangeBearingToPoint(const core::Observation& observation, Eigen::Vector2d* point,
                         Eigen::Matrix2d* information) {
  const double range = observation.z.x(), bearing = observation.z.y();
  const double c = std::cos(bearing), s = std::sin(bearing);
  *point = Eigen::Vector2d(range * c, range * s);
  Eigen::Matrix2d jacobian;
  jacobian << c, -range * s, s, range * c;
  const Eigen::Matrix2d inverse = jacobian.inverse();
  *information = inverse.transpose() * observation.information * inverse;
  *information = 0.5 * (*information + information->transpose());
}

void MotionToRelative(const core::Problem2d& problem, const core::VelocityMotionConstraint& motion,
                      core::Pose2* z, Eigen::Matrix3d* information) {
  *z = core::PredictVelocityMotion(core::Pose2::Zero(), motion.control);
  const double phi = problem.poses[motion.from].z() + z->z();
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  rotation.topLeftCorner<2, 2>() = core::Rotation2(phi);
  *information = rotation.transpose() * motion.information * rotation;
  *information = 0.5 * (*information + information->transpose());
}

// Ends the line in *line, appends it to `file` and clears it.
Status FlushLine(WritableFile* file, std::string* line) {
  line->push_back('\n');
  Status status = file->Append(*line);
  line->clear();
  return status;
}

// Only range-bearing and point-xy observations have a g2o edge (EDGE_SE2_XY),
// and a range-bearing one converts only at a positive range.
Status CheckObservationsWritable(const core::Problem2d& problem, const std::string& context) {
  for (size_t k = 0; k < problem.observations.size(); ++k) {
    const auto& observation = problem.observations[k];
    if (observation.kind != core::ObservationKind::kRangeBearing &&
        observation.kind != core::ObservationKind::kPointXY) {
      return Status::InvalidArgument(context + ": observations[" + std::to_string(k) + "] is a " +
                                     core::ObservationKindName(observation.kind) +
                                     " observation; expected range-bearing or point-xy (g2o "
                                     "has no edge for the others)");
    }
    if (observation.kind == core::ObservationKind::kRangeBearing && !(observation.z.x() > 0.0)) {
      return Status::InvalidArgument(
          context + ": observations[" + std::to_string(k) + "] range is " +
          FormatDouble(observation.z.x()) +
          "; expected range > 0 to convert it to EDGE_SE2_XY (the polar Jacobian is singular)");
    }
  }
  return Status::Ok();
}

// The renumbering comment, VERTEX_SE2, VERTEX_XY (ids + offset) and FIX.
Status AppendVertices(WritableFile* file, const core::Problem2d& problem, int64_t offset) {
  using internal::AppendField;
  std::string line;
  if (offset != 0) {
    AppendField(&line, "# graphslam: feature ids renumbered: VERTEX_XY id = feature id +");
    AppendField(&line, offset);
    GS_RETURN_IF_ERROR(FlushLine(file, &line));
  }
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    AppendField(&line, "VERTEX_SE2");
    AppendField(&line, problem.pose_ids[i]);
    for (int k = 0; k < 3; ++k) AppendField(&line, problem.poses[i][k]);
    GS_RETURN_IF_ERROR(FlushLine(file, &line));
  }
  for (int32_t i = 0; i < problem.num_features(); ++i) {
    AppendField(&line, "VERTEX_XY");
    AppendField(&line, problem.feature_ids[i] + offset);
    AppendField(&line, problem.features[i].x());
    AppendField(&line, problem.features[i].y());
    GS_RETURN_IF_ERROR(FlushLine(file, &line));
  }
  for (int32_t i = 0; i < problem.num_poses(); ++i) {
    if (!problem.pose_fixed[i]) continue;
    AppendField(&line, "FIX");
    AppendField(&line, problem.pose_ids[i]);
    GS_RETURN_IF_ERROR(FlushLine(file, &line));
  }
  return Status::Ok();
}

Status AppendPoseEdge(WritableFile* file, const core::Problem2d& problem, int32_t from,
                      int32_t to, const core::Pose2& z, const Eigen::Matrix3d& information) {
  std::string line;
  internal::AppendField(&line, "EDGE_SE2");
  internal::AppendField(&line, problem.pose_ids[from]);
  internal::AppendField(&line, problem.pose_ids[to]);
  for (int k = 0; k < 3; ++k) internal::AppendField(&line, z[k]);
  internal::AppendUpperTriangle(&line, information);
  return FlushLine(file, &line);
}

// EDGE_SE2 (relative poses, then motions as relative poses), EDGE_SE2_XY
// (observations as points in the pose frame), EDGE_PRIOR_SE2_XY (GPS).
Status AppendEdges(WritableFile* file, const core::Problem2d& problem, int64_t offset) {
  using internal::AppendField;
  using internal::AppendUpperTriangle;
  for (const auto& constraint : problem.relative_poses) {
    GS_RETURN_IF_ERROR(AppendPoseEdge(file, problem, constraint.from, constraint.to, constraint.z,
                                      constraint.information));
  }
  for (const auto& motion : problem.motions) {
    core::Pose2 z;
    Eigen::Matrix3d information;
    MotionToRelative(problem, motion, &z, &information);
    GS_RETURN_IF_ERROR(AppendPoseEdge(file, problem, motion.from, motion.to, z, information));
  }
  std::string line;
  for (const auto& observation : problem.observations) {
    Eigen::Vector2d point = observation.z;
    Eigen::Matrix2d information = observation.information;
    if (observation.kind == core::ObservationKind::kRangeBearing) {
      RangeBearingToPoint(observation, &point, &information);
    }
    AppendField(&line, "EDGE_SE2_XY");
    AppendField(&line, problem.pose_ids[observation.pose]);
    AppendField(&line, problem.feature_ids[observation.feature] + offset);
    AppendField(&line, point.x());
    AppendField(&line, point.y());
    AppendUpperTriangle(&line, information);
    GS_RETURN_IF_ERROR(FlushLine(file, &line));
  }
  for (const auto& gps : problem.gps) {
    AppendField(&line, "EDGE_PRIOR_SE2_XY");
    AppendField(&line, problem.pose_ids[gps.pose]);
    AppendField(&line, gps.z.x());
    AppendField(&line, gps.z.y());
    AppendUpperTriangle(&line, gps.information);
    GS_RETURN_IF_ERROR(FlushLine(file, &line));
  }
  return Status::Ok();
}

}  // namespace

StatusOr<int64_t> G2oFeatureIdOffset(const core::Problem2d& problem) {
  if (problem.feature_ids.empty() || problem.pose_ids.empty()) return int64_t{0};
  std::vector<int64_t> poses(problem.pose_ids.begin(), problem.pose_ids.end());
  std::sort(poses.begin(), poses.end());
  bool collide = false;
  for (int64_t id : problem.feature_ids) {
    if (std::binary_search(poses.begin(), poses.end(), id)) {
      collide = true;
      break;
    }
  }
  if (!collide) return int64_t{0};
  const auto [min_feature, max_feature] =
      std::minmax_element(problem.feature_ids.begin(), problem.feature_ids.end());
  // offset = max pose + 1 - min feature; the largest written id is
  // max feature + offset. Both in __int128 so the check cannot overflow.
  const __int128 offset = static_cast<__int128>(poses.back()) + 1 - *min_feature;
  const __int128 largest = static_cast<__int128>(*max_feature) + offset;
  if (largest > std::numeric_limits<int64_t>::max() ||
      offset > std::numeric_limits<int64_t>::max())
    return Status::InvalidArgument(
        "feature ids " + std::to_string(*min_feature) + ".." + std::to_string(*max_feature) +
        " collide with pose ids and cannot be renumbered past the largest pose id " +
        std::to_string(poses.back()) + "; expected ids that fit g2o's one int64 id space");
  return static_cast<int64_t>(offset);
}

Status WriteG2o(const core::Problem2d& problem, const std::string& path, Env* env) {
  const std::string context = "writing " + path;
  GS_RETURN_IF_ERROR(internal::ValidateProblemForWriting(problem, /*shared_id_space=*/false)
                         .WithContext(context));
  StatusOr<int64_t> offset_or = G2oFeatureIdOffset(problem);
  if (!offset_or.ok()) return offset_or.status().WithContext(context);
  const int64_t offset = *offset_or;
  GS_RETURN_IF_ERROR(CheckObservationsWritable(problem, context));
  if (env == nullptr) env = Env::Default();
  return WriteFileAtomically(env, path, [&problem, offset](WritableFile* file) -> Status {
    GS_RETURN_IF_ERROR(AppendVertices(file, problem, offset));
    return AppendEdges(file, problem, offset);
  });
}

}  // namespace graphslam::storage
