#include "storage/toro_reader.h"

#include <unordered_map>
#include <utility>

#include "storage/internal/text_reader.h"
#include "storage/internal/upper_triangle.h"
#include "storage/isam_3d_reader.h"

namespace graphslam::storage {
namespace {

// Poses by id, created on first mention; a VERTEX line gives the guess.
template <typename Problem, typename Pose>
class PoseTable {
 public:
  // `origin`: the placeholder guess of a pose no VERTEX line defines.
  PoseTable(Problem* problem, Pose origin) : problem_(problem), origin_(std::move(origin)) {}

  int32_t Mention(int64_t id, int32_t line) {
    auto [it, added] = index_.emplace(id, problem_->num_poses());
    if (added) problem_->AddPose(id, origin_, /*initialized=*/false, line);
    return it->second;
  }

  Status Define(int64_t id, const Pose& pose, const internal::LineReader& reader) {
    const int32_t i = Mention(id, reader.line_number());
    if (problem_->pose_initialized[i] != 0)
      return reader.Error(std::string(reader.fields()[0]) + " defines pose " +
                          std::to_string(id) + " again (first at line " +
                          std::to_string(problem_->pose_lines[i]) +
                          "); expected one VERTEX line per pose");
    problem_->poses[i] = pose;
    problem_->pose_initialized[i] = 1;
    problem_->pose_lines[i] = reader.line_number();
    return Status::Ok();
  }

 private:
  Problem* problem_;
  Pose origin_;
  std::unordered_map<int64_t, int32_t> index_;
};

// Both ids of an edge, distinct.
Status ReadEdgeIds(const internal::LineReader& reader, int64_t* from, int64_t* to) {
  GS_ASSIGN_OR_RETURN(*from, reader.Id(1, "from id"));
  GS_ASSIGN_OR_RETURN(*to, reader.Id(2, "to id"));
  if (*from == *to)
    return reader.Error(std::string(reader.fields()[0]) + " connects pose " +
                        std::to_string(*from) + " to itself; expected two distinct poses");
  return Status::Ok();
}

bool IsThreeDimensionalTag(std::string_view tag) { return tag == "VERTEX3" || tag == "EDGE3"; }
bool IsTwoDimensionalTag(std::string_view tag) {
  return tag == "VERTEX2" || tag == "EDGE2" || tag == "BR" || tag == "EQUIV";
}

}  // namespace

StatusOr<core::Problem2d> ReadToro(const std::string& path, core::InformationRepairs* repairs) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  core::Problem2d problem;
  problem.source = path;
  PoseTable<core::Problem2d, core::Pose2> poses(&problem, core::Pose2::Zero());
  std::unordered_map<int64_t, int32_t> landmarks;
  while (reader->Next()) {
    const std::string_view tag = reader->fields()[0];
    if (tag == "VERTEX2") {
      GS_RETURN_IF_ERROR(reader->ExpectFieldCount(5));
      GS_ASSIGN_OR_RETURN(const int64_t id, reader->Id(1, "id"));
      double v[3];
      GS_RETURN_IF_ERROR(reader->Doubles(2, 3, "estimate", v));
      GS_RETURN_IF_ERROR(poses.Define(id, core::Pose2(v[0], v[1], v[2]), *reader));
    } else if (tag == "EDGE2") {
      GS_RETURN_IF_ERROR(reader->ExpectFieldCount(12));
      int64_t from = 0, to = 0;
      GS_RETURN_IF_ERROR(ReadEdgeIds(*reader, &from, &to));
      double z[3], t[6];
      GS_RETURN_IF_ERROR(reader->Doubles(3, 3, "measurement", z));
      GS_RETURN_IF_ERROR(reader->Doubles(6, 6, "information", t));
      core::RelativePoseConstraint c;
      c.z = core::Pose2(z[0], z[1], z[2]);
      // TORO order I11 I12 I22 I33 I13 I23 (x, y, theta).
      c.information << t[0], t[1], t[4],  //
          t[1], t[2], t[5],               //
          t[4], t[5], t[3];
      if (!internal::IsPositiveDefinite(c.information) &&
          !core::RepairAndCount(repairs, reader->line_number(), &c.information))
        return reader->Error("EDGE2 information " + internal::UpperTriangleString(t, 6) +
                             " is not positive definite; expected a symmetric positive definite "
                             "matrix (TORO order I11 I12 I22 I33 I13 I23)");
      c.line = reader->line_number();
      c.from = poses.Mention(from, c.line);
      c.to = poses.Mention(to, c.line);
      problem.relative_poses.push_back(c);
    } else if (tag == "BR") {
      GS_RETURN_IF_ERROR(reader->ExpectFieldCount(7));
      GS_ASSIGN_OR_RETURN(const int64_t pose, reader->Id(1, "pose id"));
      GS_ASSIGN_OR_RETURN(const int64_t landmark, reader->Id(2, "landmark id"));
      GS_ASSIGN_OR_RETURN(const double bearing, reader->Double(3, "bearing"));
      GS_ASSIGN_OR_RETURN(const double range, reader->Double(4, "range"));
      GS_ASSIGN_OR_RETURN(const double sigma_bearing, reader->Double(5, "bearing sigma"));
      GS_ASSIGN_OR_RETURN(const double sigma_range, reader->Double(6, "range sigma"));
      if (!(sigma_bearing > 0.0) || !(sigma_range > 0.0))
        return reader->Error("BR sigmas (bearing " + internal::FormatDouble(sigma_bearing) +
                             ", range " + internal::FormatDouble(sigma_range) +
                             ") are not both positive; expected standard deviations > 0");
      core::Observation o;
      o.kind = core::ObservationKind::kRangeBearing;
      o.z = Eigen::Vector2d(range, bearing);
      o.information = Eigen::Vector2d(1.0 / (sigma_range * sigma_range),
                                      1.0 / (sigma_bearing * sigma_bearing))
                          .asDiagonal();
      o.line = reader->line_number();
      o.pose = poses.Mention(pose, o.line);
      auto [it, added] = landmarks.emplace(landmark, problem.num_features());
      if (added) problem.AddFeature(landmark, core::Point2::Zero(), /*initialized=*/false);
      o.feature = it->second;
      problem.observations.push_back(o);
    } else if (tag == "EQUIV") {
      GS_RETURN_IF_ERROR(reader->ExpectFieldCount(3));
      int64_t a = 0, b = 0;
      GS_RETURN_IF_ERROR(ReadEdgeIds(*reader, &a, &b));
    } else if (IsThreeDimensionalTag(tag)) {
      return reader->Unsupported(std::string(tag) +
                                 " is a 3-D record in a 2-D file; expected VERTEX2, EDGE2, BR or "
                                 "EQUIV");
    } else {
      return reader->Unsupported("unknown record '" + std::string(tag) +
                                 "'; expected VERTEX2, EDGE2, BR or EQUIV (TORO / GTSAM .graph)");
    }
  }
  GS_RETURN_IF_ERROR(reader->status());
  if (problem.num_poses() == 0)
    return Status::Corruption(reader->name() +
                              ": has no VERTEX2, EDGE2 or BR record; expected a 2-D .graph file");
  return problem;
}

StatusOr<core::Problem3d> ReadToro3d(const std::string& path, core::InformationRepairs* repairs) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  core::Problem3d problem;
  problem.source = path;
  PoseTable<core::Problem3d, core::Pose3> poses(&problem, core::Pose3::Identity());
  while (reader->Next()) {
    const std::string_view tag = reader->fields()[0];
    if (tag == "VERTEX3") {
      GS_RETURN_IF_ERROR(reader->ExpectFieldCount(8));
      GS_ASSIGN_OR_RETURN(const int64_t id, reader->Id(1, "id"));
      double v[6];
      GS_RETURN_IF_ERROR(reader->Doubles(2, 6, "estimate", v));
      core::Pose3 pose;
      pose.t = Eigen::Vector3d(v[0], v[1], v[2]);
      pose.q = QuaternionFromRollPitchYaw(v[3], v[4], v[5]);
      GS_RETURN_IF_ERROR(poses.Define(id, pose, *reader));
    } else if (tag == "EDGE3") {
      GS_RETURN_IF_ERROR(reader->ExpectFieldCount(30));
      int64_t from = 0, to = 0;
      GS_RETURN_IF_ERROR(ReadEdgeIds(*reader, &from, &to));
      double v[6], upper[21];
      GS_RETURN_IF_ERROR(reader->Doubles(3, 6, "measurement", v));
      GS_RETURN_IF_ERROR(reader->Doubles(9, 21, "information", upper));
      core::RelativePose3Constraint c;
      c.z.t = Eigen::Vector3d(v[0], v[1], v[2]);
      c.z.q = QuaternionFromRollPitchYaw(v[3], v[4], v[5]);
      c.information = internal::SymmetricFromUpper<6>(upper);
      if (!internal::IsPositiveDefiniteMatrix(c.information) &&
          !core::RepairAndCount(repairs, reader->line_number(), &c.information))
        return reader->Error("EDGE3 information " + internal::UpperTriangleString(upper, 21) +
                             " is not positive definite; expected a symmetric positive definite "
                             "matrix over (x, y, z, roll, pitch, yaw), upper triangle row first");
      // Angles -> vec(q) = angles / 2 (header).
      c.information.rightCols<3>() *= 2.0;
      c.information.bottomRows<3>() *= 2.0;
      c.line = reader->line_number();
      c.from = poses.Mention(from, c.line);
      c.to = poses.Mention(to, c.line);
      problem.relative_poses.push_back(c);
    } else if (IsTwoDimensionalTag(tag)) {
      return reader->Unsupported(std::string(tag) +
                                 " is a 2-D record in a 3-D file; expected VERTEX3 or EDGE3");
    } else {
      return reader->Unsupported("unknown record '" + std::string(tag) +
                                 "'; expected VERTEX3 or EDGE3 (TORO / GTSAM .graph)");
    }
  }
  GS_RETURN_IF_ERROR(reader->status());
  if (problem.num_poses() == 0)
    return Status::Corruption(reader->name() +
                              ": has no VERTEX3 or EDGE3 record; expected a 3-D .graph file");
  return problem;
}

}  // namespace graphslam::storage
