// ChunkSource: where the solver gets its observation chunks from.
//
// The solver makes one (or a few) streaming passes over the chunks per
// iteration, loading each through Load(); it never needs all of them at once.
// An in-memory source (partition/in_memory_chunk_source.h) and a disk-backed
// one (storage/, out-of-core) implement it, so that going out of core swaps the
// source, not the algorithm.
//
// THREAD SAFETY: Load() may be called concurrently for distinct chunks.
#pragma once

#include <cstdint>

#include "core/observation_chunk.h"
#include "core/status.h"

namespace graphslam::core {

class ChunkSource {
 public:
  virtual ~ChunkSource() = default;
  virtual int64_t NumChunks() const = 0;
  // Fills *chunk with chunk `index` (reusing its storage). Errors name the
  // chunk and the offending record.
  virtual Status Load(int64_t index, ObservationChunk* chunk) const = 0;
};

}  // namespace graphslam::core
