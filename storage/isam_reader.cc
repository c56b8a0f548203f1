#include "storage/isam_reader.h"

#include <string_view>
#include <unordered_map>

#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;

bool IsThreeDimensionalTag(std::string_view tag) {
  return tag == "EDGE3" || tag == "POINT3" || tag == "LANDMARK3" || tag == "POSE3" ||
         tag == "VERTEX3" || tag.find("SE3") != std::string_view::npos;
}

class IsamParser {
 public:
  IsamParser(const std::string& path, core::InformationRepairs* repairs)
      : path_(path), repairs_(repairs) {}

  StatusOr<core::Problem2d> Parse() {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(path_));
    problem_.source = path_;
    while (reader->Next()) GS_RETURN_IF_ERROR(ParseLine(*reader));
    GS_RETURN_IF_ERROR(reader->status());
    if (problem_.num_poses() == 0) {
      return Status::Corruption(reader->name() +
                                ": has no ODOMETRY, EDGE2 or LANDMARK records; expected an iSAM "
                                "2-D file");
    }
    return std::move(problem_);
  }

 private:
  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "ODOMETRY" || tag == "EDGE2") return ParseOdometry(reader);
    if (tag == "LANDMARK") return ParseLandmark(reader);
    if (IsThreeDimensionalTag(tag)) {
      return reader.Unsupported(std::string(tag) +
                                " is a 3-D record; expected a 2-D file (3-D is not supported)");
    }
    return reader.Unsupported("unknown tag '" + std::string(tag) +
                              "'; expected ODOMETRY, EDGE2 or LANDMARK");
  }

  Status ParseOdometry(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(12));
    GS_ASSIGN_OR_RETURN(const int64_t from_id, reader.Id(1, "from id"));
    GS_ASSIGN_OR_RETURN(const int64_t to_id, reader.Id(2, "to id"));
    double z[3];
    double r[6];
    GS_RETURN_IF_ERROR(reader.Doubles(3, 3, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(6, 6, "sqrt information", r,
                                       internal::Magnitude::kSqrtInformation));
    Eigen::Matrix3d root;
    root << r[0], r[1], r[2],  //
        0.0, r[3], r[4],       //
        0.0, 0.0, r[5];
    Eigen::Matrix3d information = root.transpose() * root;
    if ((r[0] == 0.0 || r[3] == 0.0 || r[5] == 0.0 || !internal::IsPositiveDefinite(information)) &&
        !core::RepairAndCount(repairs_, reader.line_number(), &information)) {
      return reader.Error(std::string(reader.fields()[0]) + " square-root information " +
                          internal::UpperTriangleString(r, 6) +
                          " is singular; expected an upper-triangular R with a non-zero "
                          "diagonal (sxx sxy sxt syy syt stt)");
    }
    if (from_id == to_id) {
      return reader.Error(std::string(reader.fields()[0]) + " connects pose " +
                          std::to_string(from_id) + " to itself; expected two distinct poses");
    }
    core::RelativePoseConstraint constraint;
    constraint.from = PoseIndex(from_id);
    constraint.to = PoseIndex(to_id);
    constraint.z = core::Pose2(z[0], z[1], z[2]);
    constraint.information = information;
    constraint.line = reader.line_number();
    problem_.relative_poses.push_back(constraint);
    return Status::Ok();
  }

  Status ParseLandmark(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(8));
    GS_ASSIGN_OR_RETURN(const int64_t pose_id, reader.Id(1, "pose id"));
    GS_ASSIGN_OR_RETURN(const int64_t landmark_id, reader.Id(2, "landmark id"));
    double z[2];
    double r[3];
    GS_RETURN_IF_ERROR(reader.Doubles(3, 2, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(5, 3, "sqrt information", r,
                                       internal::Magnitude::kSqrtInformation));
    Eigen::Matrix2d root;
    root << r[0], r[1], 0.0, r[2];
    Eigen::Matrix2d information = root.transpose() * root;
    if ((r[0] == 0.0 || r[2] == 0.0 || !internal::IsPositiveDefinite(information)) &&
        !core::RepairAndCount(repairs_, reader.line_number(), &information)) {
      return reader.Error("LANDMARK square-root information " +
                          internal::UpperTriangleString(r, 3) +
                          " is singular; expected an upper-triangular R with a non-zero "
                          "diagonal (sxx sxy syy)");
    }
    core::Observation observation;
    observation.pose = PoseIndex(pose_id);
    observation.feature = LandmarkIndex(landmark_id);
    observation.kind = core::ObservationKind::kPointXY;
    observation.z = Eigen::Vector2d(z[0], z[1]);
    observation.information = information;
    observation.line = reader.line_number();
    problem_.observations.push_back(observation);
    return Status::Ok();
  }

  int32_t PoseIndex(int64_t id) {
    const auto [it, inserted] = poses_.try_emplace(id, problem_.num_poses());
    if (inserted) problem_.AddPose(id, core::Pose2::Zero(), /*initialized=*/false, /*line=*/0);
    return it->second;
  }

  int32_t LandmarkIndex(int64_t id) {
    const auto [it, inserted] = landmarks_.try_emplace(id, problem_.num_features());
    if (inserted) problem_.AddFeature(id, core::Point2::Zero(), /*initialized=*/false);
    return it->second;
  }

  const std::string path_;
  core::InformationRepairs* const repairs_;  // null: reject singular R
  core::Problem2d problem_;
  std::unordered_map<int64_t, int32_t> poses_;
  std::unordered_map<int64_t, int32_t> landmarks_;
};

}  // namespace

StatusOr<core::Problem2d> ReadIsam(const std::string& path, core::InformationRepairs* repairs) {
  return IsamParser(path, repairs).Parse();
}

}  // namespace graphslam::storage
