#include "storage/g2o_reader.h"

#include <string_view>
#include <vector>

#include "core/information_repair.h"
#include "core/unidentified_features.h"
#include "storage/internal/g2o_graph.h"
#include "storage/internal/g2o_parser.h"
#include "storage/internal/g2o_records.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

using internal::LineReader;
using Graph2d = internal::G2oGraph<internal::G2o2d>;

bool IsThreeDimensionalTag(std::string_view tag) {
  return tag.find("SE3") != std::string_view::npos || tag.find("XYZ") != std::string_view::npos ||
         tag.find("3D") != std::string_view::npos || tag.find("QUAT") != std::string_view::npos;
}

constexpr const char* kKnownTags =
    "VERTEX_SE2, VERTEX_XY, EDGE_SE2, EDGE_SE2_XY, EDGE_PRIOR_SE2_XY or FIX";

// What only the 2-D reader has (internal/g2o_parser.h: the Dialect):
// DATA_FEATURE_POINTXY and the message for 3-D tags.
class G2o2dDialect {
 public:
  using Graph = internal::G2o2d;

  void OnPoseVertex(int32_t index) { last_pose_ = index; }
  Status CheckPointEdgeExtra(const LineReader&) const { return Status::Ok(); }

  Status ParseOther(const LineReader& reader, std::string_view tag, Graph2d* graph) {
    if (tag == "DATA_FEATURE_POINTXY") return ParseFeatureData(reader, graph);
    if (IsThreeDimensionalTag(tag)) {
      return reader.Unsupported(std::string(tag) +
                                " is a 3-D element; expected a 2-D graph (3-D is not supported)");
    }
    return reader.Unsupported("unknown tag '" + std::string(tag) + "'; expected " + kKnownTags);
  }

 private:
  // DATA_FEATURE_POINTXY a b x y xx xy yy: a point observation without
  // landmark id from the VERTEX_SE2 defined last; it gets a feature of its own
  // (id core::kNoFeatureId) for data association to merge.
  Status ParseFeatureData(const LineReader& reader, Graph2d* graph) const {
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
        graph->repairs(), &observation.information));
    observation.pose = last_pose_;
    observation.feature = graph->problem().AddFeature(core::kNoFeatureId, core::Point2::Zero(),
                                                      /*initialized=*/false);
    observation.kind = core::ObservationKind::kPointXY;
    observation.z = Eigen::Vector2d(z[0], z[1]);
    observation.line = reader.line_number();
    graph->problem().observations.push_back(observation);
    return Status::Ok();
  }

  int32_t last_pose_ = -1;  // the VERTEX_SE2 defined last (DATA_FEATURE_POINTXY's pose)
};

}  // namespace

StatusOr<core::Problem2d> ReadG2o(const std::string& path, core::InformationRepairs* repairs) {
  return internal::G2oParser<G2o2dDialect>(repairs).Parse(path);
}

}  // namespace graphslam::storage
