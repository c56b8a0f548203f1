// The line dispatch of a g2o reader, written once over a Dialect that names
// the dimension's graph traits (internal/g2o_graph.h: G2o2d, G2o3d) and
// keeps what only that dimension has:
//
//   pose vertex, point vertex, relative pose,   -> internal/g2o_records.h,
//   point observation, position prior, FIX         tags from Dialect::Graph
//   any other tag                                -> Dialect::ParseOther
//
// A Dialect (storage/g2o_reader.cc: 2-D, storage/g2o_3d_reader.cc: 3-D) has
//   using Graph;                                  // G2o2d or G2o3d
//   void OnPoseVertex(int32_t index);             // the pose just defined
//   Status CheckPointEdgeExtra(const LineReader&);  // the fields between a
//                    point edge's ids and z (Graph::kPointEdgeExtraFields)
//   Status ParseOther(const LineReader&, std::string_view tag, G2oGraph<Graph>*);
//
// THREAD SAFETY: one parser per read. ALLOCATION: the graph's.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "core/information_repair.h"
#include "core/status.h"
#include "storage/internal/g2o_graph.h"
#include "storage/internal/g2o_records.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage::internal {

template <class Dialect>
class G2oParser {
 public:
  using Graph = typename Dialect::Graph;

  explicit G2oParser(core::InformationRepairs* repairs) : graph_(repairs) {}

  StatusOr<typename Graph::Problem> Parse(const std::string& path) {
    return graph_.Read(path, [this](const LineReader& reader) { return ParseLine(reader); });
  }

 private:
  using Edges = G2oGraph<Graph>;

  Status ParseLine(const LineReader& reader) {
    const std::string_view tag = reader.fields()[0];
    if (tag == Graph::kPoseVertexTag) return ParsePoseVertex(reader);
    if (tag == Graph::kPointVertexTag) return ParseG2oPointVertex(reader, &graph_);
    if (tag == Edges::Tag(G2oEdgeKind::kRelativePose)) return ParseG2oRelativePose(reader, &graph_);
    if (tag == Edges::Tag(G2oEdgeKind::kPointObservation))
      return ParsePointEdge(reader, G2oEdgeKind::kPointObservation);
    if (tag == Edges::Tag(G2oEdgeKind::kPositionPrior))
      return ParsePointEdge(reader, G2oEdgeKind::kPositionPrior);
    if (tag == Edges::Tag(G2oEdgeKind::kFix)) return graph_.AddFix(reader);
    return dialect_.ParseOther(reader, tag, &graph_);
  }

  Status ParsePoseVertex(const LineReader& reader) {
    GS_ASSIGN_OR_RETURN(const int32_t index, ParseG2oPoseVertex(reader, &graph_));
    dialect_.OnPoseVertex(index);
    return Status::Ok();
  }

  Status ParsePointEdge(const LineReader& reader, G2oEdgeKind kind) {
    return ParseG2oPointEdge(
        reader, kind, Graph::kPointEdgeExtraFields, &graph_,
        [this](const LineReader& line) { return dialect_.CheckPointEdgeExtra(line); });
  }

  Edges graph_;
  Dialect dialect_;
};

}  // namespace graphslam::storage::internal
