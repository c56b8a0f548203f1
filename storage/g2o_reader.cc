#include "storage/g2o_reader.h"

#include <string_view>
#include <vector>

#include "core/information_repair.h"
#include "core/unidentified_features.h"
#include "storage/internal/g2o_graph.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
using VertexKind = internal::G2oVertexKind;

using Graph = internal::G2oGraph<internal::G2o2d>;
using internal::G2oEdgeKind;

bool IsThreeDimensionalTag(std::string_view tag) {
  return tag.find("SE3") != std::string_view::npos || tag.find("XYZ") != std::string_view::npos ||
         tag.find("3D") != std::string_view::npos || tag.find("QUAT") != std::string_view::npos;
}

constexpr const char* kKnownTags =
    "VERTEX_SE2, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY, EDGE_PRIOR_SE2_XY or FIX";

class G2oParser {
 public:
  explicit G2oParser(core::InformationRepairs* repairs) : repairs_(repairs) {}

  StatusOr<core::Problem2d> Parse(const std::string& path) {
    return graph_.Read(path, [this](const LineReader& reader) { return ParseLine(reader); });
  }

 private:
  // With repair on (core/information_repair.h): repairs and counts a matrix
  // that is not positive definite; false when repair is off (reject it).
  template <typename Matrix>
  bool Repaired(const LineReader& reader, Matrix* information) {
    return core::RepairAndCount(repairs_, reader.line_number(), information);
  }

  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "VERTEX_SE2") return ParseVertex(reader, VertexKind::kPose);
    if (tag == "VERTEX_XY") return ParseVertex(reader, VertexKind::kFeature);
    if (tag == "EDGE_SE2") return ParseRelativePose(reader);
    if (tag == "EDGE_SE2_XY") return ParsePointEdge(reader, G2oEdgeKind::kPointObservation);
    if (tag == "EDGE_PRIOR_SE2_XY") return ParsePointEdge(reader, G2oEdgeKind::kPositionPrior);
    if (tag == "FIX") return graph_.AddFix(reader);
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
    GS_RETURN_IF_ERROR(graph_.vertices().CheckUnique(reader, id, kind));
    core::Problem2d& problem = graph_.problem();
    int32_t index = 0;
    if (pose) {
      index = problem.AddPose(id, core::Pose2(values[0], values[1], values[2]),
                              /*initialized=*/true, reader.line_number());
      last_pose_ = index;
    } else {
      index = problem.AddFeature(id, core::Point2(values[0], values[1]), /*initialized=*/true);
    }
    graph_.vertices().Define(id, kind, index, reader.line_number());
    return Status::Ok();
  }

  Status ParseRelativePose(const LineReader& reader) {
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(12));
    Graph::Pending item;
    item.kind = G2oEdgeKind::kRelativePose;
    item.line = reader.line_number();
    GS_ASSIGN_OR_RETURN(item.ids[0], reader.Id(1, "from id"));
    GS_ASSIGN_OR_RETURN(item.ids[1], reader.Id(2, "to id"));
    double z[3];
    double upper[6];
    GS_RETURN_IF_ERROR(reader.Doubles(3, 3, "measurement", z));
    GS_RETURN_IF_ERROR(reader.Doubles(6, 6, "information", upper, internal::Magnitude::kInformation));
    item.pose = core::Pose2(z[0], z[1], z[2]);
    item.pose_information = internal::SymmetricFromUpper3(upper);
    if (!internal::IsPositiveDefinite(item.pose_information) &&
        !Repaired(reader, &item.pose_information)) {
      return reader.Error("EDGE_SE2 information " + internal::UpperTriangleString(upper, 6) +
                          " is not positive definite; expected a symmetric positive definite "
                          "matrix (upper triangle xx xy xt yy yt tt)");
    }
    if (item.ids[0] == item.ids[1]) {
      return reader.Error("EDGE_SE2 connects vertex " + std::to_string(item.ids[0]) +
                          " to itself; expected two distinct vertices");
    }
    graph_.Add(item);
    return Status::Ok();
  }

  // EDGE_SE2_XY pose landmark x y xx xy yy, EDGE_PRIOR_SE2_XY pose x y xx xy yy.
  Status ParsePointEdge(const LineReader& reader, G2oEdgeKind kind) {
    const bool observation = kind == G2oEdgeKind::kPointObservation;
    const size_t ids = observation ? 2 : 1;
    GS_RETURN_IF_ERROR(reader.ExpectFieldCount(1 + ids + 2 + 3));
    Graph::Pending item;
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
    item.point = Eigen::Vector2d(z[0], z[1]);
    item.point_information = internal::SymmetricFromUpper2(upper);
    if (!internal::IsPositiveDefinite(item.point_information) &&
        !Repaired(reader, &item.point_information)) {
      return reader.Error(std::string(Graph::Tag(kind)) + " information " +
                          internal::UpperTriangleString(upper, 3) +
                          " is not positive definite; expected a symmetric positive definite "
                          "matrix (upper triangle xx xy yy)");
    }
    graph_.Add(item);
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
    observation.feature = graph_.problem().AddFeature(core::kNoFeatureId, core::Point2::Zero(),
                                                      /*initialized=*/false);
    observation.kind = core::ObservationKind::kPointXY;
    observation.z = Eigen::Vector2d(z[0], z[1]);
    observation.line = reader.line_number();
    graph_.problem().observations.push_back(observation);
    return Status::Ok();
  }

  core::InformationRepairs* const repairs_;  // null: reject non-PD information
  Graph graph_;
  int32_t last_pose_ = -1;  // the VERTEX_SE2 defined last (DATA_FEATURE_POINTXY's pose)
};

}  // namespace

StatusOr<core::Problem2d> ReadG2o(const std::string& path, core::InformationRepairs* repairs) {
  return G2oParser(repairs).Parse(path);
}

}  // namespace graphslam::storage
