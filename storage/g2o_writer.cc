#include "storage/g2o_writer.h"

#include <Eigen/LU>
#include <algorithm>
#include <limits>
#include <vector>

#include "core/se2.h"
#include "core/velocity_motion_model.h"
#include "storage/atomic_file.h"
#include "storage/internal/g2o_record_writer.h"
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

using RecordWriter = internal::G2oRecordWriter<internal::G2o2d>;

// The renumbering comment, VERTEX_SE2, VERTEX_XY (ids + offset) and FIX.
Status AppendVertices(RecordWriter* out, int64_t offset) {
  if (offset != 0) {
    std::string line;
    internal::AppendField(&line, "# graphslam: feature ids renumbered: VERTEX_XY id = feature id +");
    internal::AppendField(&line, offset);
    GS_RETURN_IF_ERROR(out->Line(line));
  }
  return out->Vertices();
}

// EDGE_SE2 (relative poses, then motions as relative poses), EDGE_SE2_XY
// (observations as points in the pose frame), EDGE_PRIOR_SE2_XY (GPS).
Status AppendEdges(RecordWriter* out, const core::Problem2d& problem) {
  GS_RETURN_IF_ERROR(out->RelativePoses());
  for (const auto& motion : problem.motions) {
    core::Pose2 z;
    Eigen::Matrix3d information;
    MotionToRelative(problem, motion, &z, &information);
    GS_RETURN_IF_ERROR(out->RelativePose(motion.from, motion.to, z, information));
  }
  for (const auto& observation : problem.observations) {
    Eigen::Vector2d point = observation.z;
    Eigen::Matrix2d information = observation.information;
    if (observation.kind == core::ObservationKind::kRangeBearing) {
      RangeBearingToPoint(observation, &point, &information);
    }
    GS_RETURN_IF_ERROR(
        out->PointObservation(observation.pose, observation.feature, point, information));
  }
  return out->PositionPriors();
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
    RecordWriter out(file, problem, offset);
    GS_RETURN_IF_ERROR(AppendVertices(&out, offset));
    return AppendEdges(&out, problem);
  });
}

}  // namespace graphslam::storage
