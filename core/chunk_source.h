// ChunkSource: where the solver gets its observation chunks from.
//
// The solver makes one (or a few) streaming passes over the chunks per
// iteration, loading each through Load(); it never needs all of them at once.
// An in-memory source (partition/ingest/in_memory_chunk_source.h) and a disk-backed
// one (storage/, out-of-core) implement it, so that going out of core swaps the
// source, not the algorithm. ChunkSource serves planar chunks, ChunkSource3d
// 3-D ones (core/observation_chunk.h).
//
// THREAD SAFETY: Load() may be called concurrently for distinct chunks.
#pragma once

#include <cstdint>

#include "core/observation_chunk.h"
#include "core/status.h"

namespace graphslam::core {

template <class ObservationT>
class BasicChunkSource {
 public:
  using Chunk = BasicObservationChunk<ObservationT>;
  virtual ~BasicChunkSource() = default;
  virtual int64_t NumChunks() const = 0;
  // Fills *chunk with chunk `index` (reusing its storage). Errors name the
  // chunk and the offending record.
  virtual Status Load(int64_t index, Chunk* chunk) const = 0;
};

using ChunkSource = BasicChunkSource<Observation>;
using ChunkSource3d = BasicChunkSource<Point3Observation>;

}  // namespace graphslam::core
