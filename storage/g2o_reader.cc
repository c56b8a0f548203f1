#include "storage/g2o_reader.h"

#include <string_view>
#include <vector>

#include "core/information_repair.h"
#include "core/unidentified_features.h"
#include "storage/internal/g2o_graph.h"
#include "storage/internal/g2o_records.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
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
  explicit G2oParser(core::InformationRepairs* repairs) : graph_(repairs) {}

  StatusOr<core::Problem2d> Parse(const std::string& path) {
    return graph_.Read(path, [this](const LineReader& reader) { return ParseLine(reader); });
  }

 private:
  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == "VERTEX_SE2") return ParsePoseVertex(reader);
    if (tag == "VERTEX_XY") return internal::ParseG2oPointVertex(reader, &graph_);
    if (tag == "EDGE_SE2") return internal::ParseG2oRelativePose(reader, &graph_);
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

  Status ParsePoseVertex(const LineReader& reader) {
    GS_ASSIGN_OR_RETURN(last_pose_, internal::ParseG2oPoseVertex(reader, &graph_));
    return Status::Ok();
  }

  // EDGE_SE2_XY pose landmark x y xx xy yy, EDGE_PRIOR_SE2_XY pose x y xx xy yy.
  Status ParsePointEdge(const LineReader& reader, G2oEdgeKind kind) {
    return internal::ParseG2oPointEdge(reader, kind, /*extra_fields=*/0, &graph_,
                                       [](const LineReader&) { return Status::Ok(); });
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
    GS_RETURN_IF_ERROR(reader.Doubles(3, 2, "measurement", z));
    core::Observation observation;
    GS_RETURN_IF_ERROR(internal::ReadG2oInformation<2>(
        reader, 5, "DATA_FEATURE_POINTXY", internal::G2o2d::kPointInformationForm,
        graph_.repairs(), &observation.information));
    observation.pose = last_pose_;
    observation.feature = graph_.problem().AddFeature(core::kNoFeatureId, core::Point2::Zero(),
                                                      /*initialized=*/false);
    observation.kind = core::ObservationKind::kPointXY;
    observation.z = Eigen::Vector2d(z[0], z[1]);
    observation.line = reader.line_number();
    graph_.problem().observations.push_back(observation);
    return Status::Ok();
  }

  Graph graph_;
  int32_t last_pose_ = -1;  // the VERTEX_SE2 defined last (DATA_FEATURE_POINTXY's pose)
};

}  // namespace

StatusOr<core::Problem2d> ReadG2o(const std::string& path, core::InformationRepairs* repairs) {
  return G2oParser(repairs).Parse(path);
}

}  // namespace graphslam::storage
