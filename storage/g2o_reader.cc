#include "storage/g2o_reader.h"

#include <string_view>
#include <unordered_map>
#include <vector>

#include "core/information_repair.h"
#include "core/unidentified_features.h"
#include "storage/internal/g2o_vertices.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
using VertexKind = internal::G2oVertexKind;

enum class PendingKind { kRelativePose, kPointObservation, kPositionPrior, kFix };

// An edge or FIX, kept with its file ids until every vertex is known (vertices
// may follow the edges that use them).
struct Pending {
  PendingKind kind;
  int64_t ids[2] = {0, 0};
  int32_t line = 0;
  core::Pose2 pose_measurement = core::Pose2::Zero();
  Eigen::Vector2d point_measurement = Eigen::Vector2d::Zero();
  Eigen::Matrix3d information3 = Eigen::Matrix3d::Identity();
  Eigen::Matrix2d information2 = Eigen::Matrix2d::Identity();
};

const char* PendingTag(PendingKind kind) {
  switch (kind) {
    case PendingKind::kRelativePose: return "EDGE_SE2";
    case PendingKind::kPointObservation: return "EDGE_SE2_XY";
    case PendingKind::kPositionPrior: return "EDGE_PRIOR_SE2_XY";
    case PendingKind::kFix: return "FIX";
  }
  return "?";
}

bool IsThreeDimensionalTag(std::string_view tag) {
  return tag.find("SE3") != std::string_view::npos || tag.find("XYZ") != std::string_view::npos ||
         tag.find("3D") != std::string_view::npos || tag.find("QUAT") != std::string_view::npos;
}

constexpr const char* kKnownTags =
    "VERTEX_SE2, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY, EDGE_PRIOR_SE2_XY or FIX";

class G2oParser {
 public:
  G2oParser(const std::string& path, core::InformationRepairs* repairs)
      : path_(path), repairs_(repairs) {}

  StatusOr<core::Problem2d> Parse() {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<LineReader> reader, LineReader::Open(path_));
    name_ = reader->name();
    problem_.source = path_;
    while (reader->Next()) GS_RETURN_IF_ERROR(ParseLine(*reader));
    GS_RETURN_IF_ERROR(reader->status());
    if (vertices_.empty() && pending_.empty()) {
      return Status::Corruption(name_ + ": has no vertices or edges; expected a g2o graph");
    }
    vertices_.Seal();
    for (const Pending& item : pending_) GS_RETURN_IF_ERROR(Resolve(item));
    return std::move(problem_);
  }

 private:
  // With repair on (core/information_repair.h): repairs and counts a matrix
  // that is not positive definite; false when repair is off (reject it).
  template <typename Matrix>
  bool Repaired(const LineReader& reader, Matrix* information) {
    if (repairs_ == nullptr) return false;
    core::RepairInformation(information);
    repairs_->Record(reader.line_number());
    return true;
  }

  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "VERTEX_SE2") return ParseVertex(reader, VertexKind::kPose);
    if (tag == "VERTEX_XY") return ParseVertex(reader, VertexKind::kFeature);
    if (tag == "EDGE_SE2") return ParseRelativePose(reader);
    if (tag == "EDGE_SE2_XY") return ParsePointEdge(reader, PendingKind::kPointObservation);
    if (tag == "EDGE_PRIOR_SE2_XY") return ParsePointEdge(reader, PendingKind::kPositionPrior);
    if (tag == "FIX") return ParseFix(reader);
    if (tag == "DATA_FEATURE_POINTXY") return ParseFeatureData(reader);
    if (IsThreeDimensionalTag(tag)) {
      return reader.Unsupported(std::string(tag) +
                                " is a 3-D element; expected a 2-D graph (3-D is not supported)");
    }
    return reader.Unsupported("unknown tag '" + std::string(tag) + "'; expected " + kKnownTags);
  }

  Status ParseVertex(const LineReader& reader, VertexKind kind) {
    const bool pose = kind == VertexKind::kPose;
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(pose ? 5 : 4));
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(1, "id"));
    double values[3] = {0.0, 0.0, 0.0};
    GS_RETURN_IF_ERROR(reader.Doubles(2, pose ? 3 : 2, "estimate", values));
    GS_RETURN_IF_ERROR(vertices_.CheckUnique(reader, id, kind));
    int32_t index = 0;
    if (pose) {
      index = problem_.AddPose(id, core::Pose2(values[0], values[1], values[2]),
                               /*initialized=*/true, reader.line_number());
      last_pose_ = index;
    } else {
      index = problem_.AddFeature(id, core::Point2(values[0], values[1]), /*initialized=*/true);
    }
    vertices_.Define(id, kind, index, reader.line_number());
    return Status::Ok();
  }

  Status ParseRelativePose(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(12));
    Pending item;
    item.kind = PendingKind::kRelativePose;
    item.line = reader.line_number();
    GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "from id"));
    GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "to id"));
    double z[3];
    double upper[6];
    GS_RETURN_IF_ERROR(reader.Doubles(3, 3, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(6, 6, "information", upper, internal::Magnitude::kInformation));
    item.pose_measurement = core::Pose2(z[0], z[1], z[2]);
    item.information3 = internal::SymmetricFromUpper3(upper);
    if (!internal::IsPositiveDefinite(item.information3) && !Repaired(reader, &item.information3)) {
      return reader.Error("EDGE_SE2 information " + internal::UpperTriangleString(upper, 6) +
                          " is not positive definite; expected a symmetric positive definite "
                          "matrix (upper triangle xx xy xt yy yt tt)");
    }
    if (item.ids[0] == item.ids[1]) {
      return reader.Error("EDGE_SE2 connects vertex " + std::to_string(item.ids[0]) +
                          " to itself; expected two distinct vertices");
    }
    pending_.push_back(item);
    return Status::Ok();
  }

  // EDGE_SE2_XY pose landmark x y xx xy yy, EDGE_PRIOR_SE2_XY pose x y xx xy yy.
  Status ParsePointEdge(const LineReader& reader, PendingKind kind) {
    const bool observation = kind == PendingKind::kPointObservation;
    const size_t ids = observation ? 2 : 1;
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(1 + ids + 2 + 3));
    Pending item;
    item.kind = kind;
    item.line = reader.line_number();
    GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "pose id"));
    if (observation) {
      GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "landmark id"));
    }
    double z[2];
    double upper[3];
    GS_RETURN_IF_ERROR(reader.Doubles(1 + ids, 2, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(3 + ids, 3, "information", upper,
                                       internal::Magnitude::kInformation));
    item.point_measurement = Eigen::Vector2d(z[0], z[1]);
    item.information2 = internal::SymmetricFromUpper2(upper);
    if (!internal::IsPositiveDefinite(item.information2) && !Repaired(reader, &item.information2)) {
      return reader.Error(std::string(PendingTag(kind)) + " information " +
                          internal::UpperTriangleString(upper, 3) +
                          " is not positive definite; expected a symmetric positive definite "
                          "matrix (upper triangle xx xy yy)");
    }
    pending_.push_back(item);
    return Status::Ok();
  }

  // DATA_FEATURE_POINTXY a b x y xx xy yy: a point observation without
  // landmark id from the VERTEX_SE2 defined last; it gets a feature of its own
  // (id core::kNoFeatureId) for data association to merge.
  Status ParseFeatureData(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(8));
    GS_RETURN_IF_ERROR(reader.Id(1, "sensor id").status());
    GS_RETURN_IF_ERROR(reader.Id(2, "dimension").status());
    if (last_pose_ < 0) {
      return reader.Error(
          "DATA_FEATURE_POINTXY comes before any VERTEX_SE2; expected it after the pose it was "
          "observed from");
    }
    double z[2];
    double upper[3];
    GS_RETURN_IF_ERROR(reader.Doubles(3, 2, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(5, 3, "information", upper, internal::Magnitude::kInformation));
    core::Observation observation;
    observation.information = internal::SymmetricFromUpper2(upper);
    if (!internal::IsPositiveDefinite(observation.information) &&
        !Repaired(reader, &observation.information)) {
      return reader.Error("DATA_FEATURE_POINTXY information " +
                          internal::UpperTriangleString(upper, 3) +
                          " is not positive definite; expected a symmetric positive definite "
                          "matrix (upper triangle xx xy yy)");
    }
    observation.pose = last_pose_;
    observation.feature =
        problem_.AddFeature(core::kNoFeatureId, core::Point2::Zero(), /*initialized=*/false);
    observation.kind = core::ObservationKind::kPointXY;
    observation.z = Eigen::Vector2d(z[0], z[1]);
    observation.line = reader.line_number();
    problem_.observations.push_back(observation);
    return Status::Ok();
  }

  Status ParseFix(const LineReader& reader) {
    std::vector<int64_t> ids;
    GS_RETURN_IF_ERROR(internal::ReadFixIds(reader, &ids));
    for (const int64_t id : ids) {
      Pending item;
      item.kind = PendingKind::kFix;
      item.line = reader.line_number();
      item.ids[0] = id;
      pending_.push_back(item);
    }
    return Status::Ok();
  }

  // The dense index of vertex `id`, which must be of `kind`; creates it in
  // edges-only files.
  StatusOr<int32_t> Lookup(int64_t id, VertexKind kind, const Pending& item) {
    return vertices_.Lookup(name_, item.line, PendingTag(item.kind), id, kind,
                            [this, id](VertexKind created) {
                              return created == VertexKind::kPose
                                         ? problem_.AddPose(id, core::Pose2::Zero(),
                                                            /*initialized=*/false, 0)
                                         : problem_.AddFeature(id, core::Point2::Zero(),
                                                               /*initialized=*/false);
                            });
  }

  Status Resolve(const Pending& item) {
    switch (item.kind) {
      case PendingKind::kRelativePose: {
        core::RelativePoseConstraint constraint;
        GS_ASSIGN_OR_RETURN(constraint.from, Lookup(item.ids[0], VertexKind::kPose, item));
        GS_ASSIGN_OR_RETURN(constraint.to, Lookup(item.ids[1], VertexKind::kPose, item));
        constraint.z = item.pose_measurement;
        constraint.information = item.information3;
        constraint.line = item.line;
        problem_.relative_poses.push_back(constraint);
        return Status::Ok();
      }
      case PendingKind::kPointObservation: {
        core::Observation observation;
        GS_ASSIGN_OR_RETURN(observation.pose, Lookup(item.ids[0], VertexKind::kPose, item));
        GS_ASSIGN_OR_RETURN(observation.feature,
                            Lookup(item.ids[1], VertexKind::kFeature, item));
        observation.kind = core::ObservationKind::kPointXY;
        observation.z = item.point_measurement;
        observation.information = item.information2;
        observation.line = item.line;
        problem_.observations.push_back(observation);
        return Status::Ok();
      }
      case PendingKind::kPositionPrior: {
        core::GpsConstraint gps;
        GS_ASSIGN_OR_RETURN(gps.pose, Lookup(item.ids[0], VertexKind::kPose, item));
        gps.z = item.point_measurement;
        gps.information = item.information2;
        gps.line = item.line;
        problem_.gps.push_back(gps);
        return Status::Ok();
      }
      case PendingKind::kFix: {
        // FIX names vertices: in a file with vertices a FIX of an unknown id
        // is an error like any edge; fixing a landmark is not supported.
        GS_ASSIGN_OR_RETURN(const int32_t pose, Lookup(item.ids[0], VertexKind::kPose, item));
        problem_.pose_fixed[pose] = 1;
        return Status::Ok();
      }
    }
    return Status::Ok();
  }

  const std::string path_;
  core::InformationRepairs* const repairs_;  // null: reject non-PD information
  std::string name_;
  core::Problem2d problem_;
  internal::G2oVertices vertices_{"VERTEX_SE2", "VERTEX_XY"};
  std::vector<Pending> pending_;
  int32_t last_pose_ = -1;  // the VERTEX_SE2 defined last (DATA_FEATURE_POINTXY's pose)
};

}  // namespace

StatusOr<core::Problem2d> ReadG2o(const std::string& path, core::InformationRepairs* repairs) {
  return G2oParser(path, repairs).Parse();
}

}  // namespace graphslam::storage
