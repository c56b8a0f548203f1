// The vertex table of a g2o graph being read, shared by the 2-D
// (storage/g2o_reader.cc) and the 3-D (storage/g2o_3d_reader.cc) readers.
//
// g2o lets edges come before the vertices they join, so a reader keeps its
// edges with their file ids and resolves them once every line is read:
//   - a file with VERTEX lines: every id an edge names must be one of them,
//     of the kind the edge expects (a pose, or a feature);
//   - an edges-only file (SE-Sync style): an id is created on first use, with
//     no initial guess (the initialization chains odometry).
// Errors are "<file>:<line>: <edge tag> ...; expected ..." as everywhere.
// FIX lines (FIX id [id ...]) are read here too: both formats share them.
//
// THREAD SAFETY: one table per reader. ALLOCATION: one map entry per vertex.
#pragma once

#include <cstdint>
#include <string>
#include <unordered_map>
#include <vector>

#include "core/status.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage::internal {

enum class G2oVertexKind { kPose, kFeature };

class G2oVertices {
 public:
  // The VERTEX tags of the format, for the messages.
  G2oVertices(const char* pose_tag, const char* feature_tag)
      : tags_{pose_tag, feature_tag} {}

  const char* Tag(G2oVertexKind kind) const { return tags_[static_cast<int>(kind)]; }
  bool empty() const { return vertices_.empty(); }

  // The vertex `id` of `kind`, defined on the reader's current line, is
  // `index`. An error if `id` is already defined.
  Status CheckUnique(const LineReader& reader, int64_t id, G2oVertexKind kind) const {
    if (const auto it = vertices_.find(id); it != vertices_.end()) {
      return reader.Error(std::string(Tag(kind)) + " id " + std::to_string(id) +
                          " is already defined at line " + std::to_string(it->second.line) +
                          " (" + Tag(it->second.kind) + "); expected unique vertex ids");
    }
    return Status::Ok();
  }
  void Define(int64_t id, G2oVertexKind kind, int32_t index, int32_t line) {
    vertices_.emplace(id, Vertex{kind, index, line});
  }

  // Call once every line is read: from then on an unknown id is an error in a
  // file with vertices, and created by `create` (kind -> index) in an
  // edges-only file.
  void Seal() { has_vertices_ = !vertices_.empty(); }

  // The dense index of vertex `id`, which must be of `kind`, for the edge
  // `edge_tag` at `name`:`line`.
  template <class Create>
  StatusOr<int32_t> Lookup(const std::string& name, int32_t line, const char* edge_tag, int64_t id,
                           G2oVertexKind kind, Create&& create) {
    const auto it = vertices_.find(id);
    if (it != vertices_.end()) {
      if (it->second.kind != kind) {
        const std::string defined = it->second.line > 0
                                        ? " (line " + std::to_string(it->second.line) + ")"
                                        : " (implicitly, by an earlier edge)";
        return CorruptionAt(name, line,
                            std::string(edge_tag) + " vertex " + std::to_string(id) + " is a " +
                                Tag(it->second.kind) + defined + "; expected a " + Tag(kind));
      }
      return it->second.index;
    }
    if (has_vertices_) {
      return CorruptionAt(name, line,
                          std::string(edge_tag) + " refers to vertex " + std::to_string(id) +
                              ", which no VERTEX line defines; expected a " + Tag(kind) + " " +
                              std::to_string(id) + " line");
    }
    const int32_t index = create(kind);
    vertices_.emplace(id, Vertex{kind, index, 0});
    return index;
  }

 private:
  struct Vertex {
    G2oVertexKind kind;
    int32_t index;  // into poses or features
    int32_t line;   // 0 if created implicitly (edges-only files)
  };
  const char* tags_[2];
  std::unordered_map<int64_t, Vertex> vertices_;
  bool has_vertices_ = false;
};

// FIX id [id ...]: appends every id to *ids.
inline Status ReadFixIds(const LineReader& reader, std::vector<int64_t>* ids) {
  if (reader.fields().size() < 2)
    return reader.Error("FIX has 1 fields; expected at least 2 (FIX id [id ...])");
  for (size_t k = 1; k < reader.fields().size(); ++k) {
    GS_ASSIGN_OR_RETURN(const int64_t id, reader.Id(k, "vertex id"));
    ids->push_back(id);
  }
  return Status::Ok();
}

}  // namespace graphslam::storage::internal
