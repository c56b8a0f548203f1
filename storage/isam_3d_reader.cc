#include "storage/isam_3d_reader.h"

#include <unordered_map>

#include "storage/internal/text_reader.h"
#include "storage/internal/upper_triangle.h"

namespace graphslam::storage {

Eigen::Quaterniond QuaternionFromRollPitchYaw(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .normalized();
}

namespace {

// The problem's poses and points by their iSAM ids, added at first mention.
class Isam3dIds {
 public:
  explicit Isam3dIds(core::Problem3d* problem) : problem_(problem) {}
  int32_t Pose(int64_t id, int32_t line) {
    auto [it, added] = poses_.emplace(id, problem_->num_poses());
    if (added) problem_->AddPose(id, core::Pose3::Identity(), /*initialized=*/false, line);
    return it->second;
  }
  int32_t Point(int64_t id) {
    auto [it, added] = points_.emplace(id, problem_->num_features());
    if (added) problem_->AddFeature(id, core::Point3::Zero(), /*initialized=*/false);
    return it->second;
  }

 private:
  core::Problem3d* const problem_;
  std::unordered_map<int64_t, int32_t> poses_, points_;
};

// EDGE3 from to x y z roll pitch yaw [S: 21 upper-triangle values]: a
// relative pose; the information on (t, angles) goes to (t, vec(q)).
Status ReadEdge3(internal::LineReader* reader, core::InformationRepairs* repairs, Isam3dIds* ids,
                 core::Problem3d* problem) {
  GS_RETURN_IF_ERROR(reader->ExpectFieldCount(9, 30));
  GS_ASSIGN_OR_RETURN(const int64_t from, reader->Id(1, "from id"));
  GS_ASSIGN_OR_RETURN(const int64_t to, reader->Id(2, "to id"));
  if (from == to)
    return reader->Error("EDGE3 connects pose " + std::to_string(from) +
                         " to itself; expected two distinct poses");
  double v[6];
  GS_RETURN_IF_ERROR(reader->Doubles(3, 6, "measurement", v));
  core::RelativePose3Constraint c;
  c.z.t = Eigen::Vector3d(v[0], v[1], v[2]);
  c.z.q = QuaternionFromRollPitchYaw(v[3], v[4], v[5]);
  if (reader->fields().size() == 30) {
    double s[21];
    GS_RETURN_IF_ERROR(reader->Doubles(9, 21, "square-root information", s,
                                       internal::Magnitude::kSqrtInformation));
    const core::Matrix6d sqrt_information = internal::UpperFromRowFirst<6>(s);
    c.information = sqrt_information.transpose() * sqrt_information;
    // Angles -> vec(q) = angles / 2 (isam_3d_reader.h).
    c.information.rightCols<3>() *= 2.0;
    c.information.bottomRows<3>() *= 2.0;
    if (!internal::IsPositiveDefiniteMatrix(c.information) &&
        !core::RepairAndCount(repairs, reader->line_number(), &c.information))
      return reader->Error("EDGE3 square-root information " +
                           internal::UpperTriangleString(s, 21) +
                           " is singular; expected an upper-triangular S with a non-zero "
                           "diagonal");
  }
  if (reader->fields().size() == 9) {
    c.information.rightCols<3>() *= 2.0;
    c.information.bottomRows<3>() *= 2.0;
  }
  c.line = reader->line_number();
  c.from = ids->Pose(from, c.line);
  c.to = ids->Pose(to, c.line);
  problem->relative_poses.push_back(c);
  return Status::Ok();
}

// POINT3 pose point x y z [S: 6 upper-triangle values]: a point in the
// pose's frame.
Status ReadPoint3(internal::LineReader* reader, core::InformationRepairs* repairs, Isam3dIds* ids,
                  core::Problem3d* problem) {
  GS_RETURN_IF_ERROR(reader->ExpectFieldCount(6, 12));
  GS_ASSIGN_OR_RETURN(const int64_t pose, reader->Id(1, "pose id"));
  GS_ASSIGN_OR_RETURN(const int64_t point, reader->Id(2, "point id"));
  double v[3];
  GS_RETURN_IF_ERROR(reader->Doubles(3, 3, "measurement", v));
  core::Point3Observation o;
  o.z = Eigen::Vector3d(v[0], v[1], v[2]);
  if (reader->fields().size() == 12) {
    double s[6];
    GS_RETURN_IF_ERROR(reader->Doubles(6, 6, "square-root information", s,
                                       internal::Magnitude::kSqrtInformation));
    const Eigen::Matrix3d sqrt_information = internal::UpperFromRowFirst<3>(s);
    o.information = sqrt_information.transpose() * sqrt_information;
    if (!internal::IsPositiveDefiniteMatrix(o.information) &&
        !core::RepairAndCount(repairs, reader->line_number(), &o.information))
      return reader->Error("POINT3 square-root information " +
                           internal::UpperTriangleString(s, 6) +
                           " is singular; expected an upper-triangular S with a non-zero "
                           "diagonal");
  }
  o.line = reader->line_number();
  o.pose = ids->Pose(pose, o.line);
  o.feature = ids->Point(point);
  problem->observations.push_back(o);
  return Status::Ok();
}

}  // namespace

StatusOr<core::Problem3d> ReadIsam3d(const std::string& path, core::InformationRepairs* repairs) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::LineReader> reader,
                      internal::LineReader::Open(path));
  core::Problem3d problem;
  problem.source = path;
  Isam3dIds ids(&problem);
  while (reader->Next()) {
    const std::string_view tag = reader->fields()[0];
    if (tag == "EDGE3") {
      GS_RETURN_IF_ERROR(ReadEdge3(reader.get(), repairs, &ids, &problem));
    } else if (tag == "POINT3") {
      GS_RETURN_IF_ERROR(ReadPoint3(reader.get(), repairs, &ids, &problem));
    } else if (tag == "EDGE2" || tag == "ODOMETRY" || tag == "LANDMARK") {
      return reader->Unsupported(std::string(tag) +
                                 " is a 2-D record in a 3-D file; expected EDGE3 or POINT3");
    } else {
      return reader->Unsupported("unknown record '" + std::string(tag) +
                                 "'; expected EDGE3 or POINT3");
    }
  }
  GS_RETURN_IF_ERROR(reader->status());
  if (problem.num_poses() == 0)
    return Status::Corruption(reader->name() + ": has no EDGE3 or POINT3 record; expected a 3-D "
                              "iSAM file");
  return problem;
}

}  // namespace graphslam::storage
