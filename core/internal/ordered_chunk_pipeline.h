// RunOrderedChunkPipeline: one streaming pass over a ChunkSource as a TBB
// pipeline with a bounded number of chunks in flight.
//
//   serial in order : hand out chunk indices 0, 1, 2, ...
//   parallel        : Load(chunk) and work(chunk, &output)   (any thread)
//   serial in order : merge(output) in chunk order
//
// Because merge() sees the outputs in chunk order whatever the thread count,
// a sum accumulated there is bit-for-bit the same with 1 or N threads (the
// "parallel equals serial" promise). At most `max_in_flight` chunks and outputs
// exist at once, which bounds memory for the out-of-core store. The first
// error (in chunk order) stops the pass and is returned.
//
// THREAD SAFETY: `work` runs concurrently on distinct chunks and outputs;
// `merge` runs serially. ALLOCATION: max_in_flight chunk and output objects,
// reused across chunks.
#pragma once

#include <tbb/parallel_pipeline.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/chunk_source.h"
#include "core/status.h"

namespace graphslam::core::internal {

// Source: a BasicChunkSource of either space (core/chunk_source.h).
template <typename Output, typename Source, typename Work, typename Merge>
Status RunOrderedChunkPipeline(const Source& source, int max_in_flight, Work&& work,
                               Merge&& merge) {
  struct Slot {
    typename Source::Chunk chunk;
    Output output;
    Status status;
  };
  const int64_t num_chunks = source.NumChunks();
  if (num_chunks == 0) return Status::Ok();
  const int tokens = std::max(1, max_in_flight);
  std::vector<std::unique_ptr<Slot>> slots(tokens);
  for (auto& slot : slots) slot = std::make_unique<Slot>();
  int64_t next = 0;
  std::atomic<bool> failed{false};
  Status first_error;

  tbb::parallel_pipeline(
      static_cast<size_t>(tokens),
      tbb::make_filter<void, Slot*>(
          tbb::filter_mode::serial_in_order,
          [&](tbb::flow_control& control) -> Slot* {
            if (next >= num_chunks || failed.load()) {
              control.stop();
              return nullptr;
            }
            Slot* slot = slots[next % tokens].get();
            slot->chunk.index = next++;
            return slot;
          }) &
          tbb::make_filter<Slot*, Slot*>(
              tbb::filter_mode::parallel,
              [&](Slot* slot) -> Slot* {
                slot->status = source.Load(slot->chunk.index, &slot->chunk);
                if (slot->status.ok()) slot->status = work(slot->chunk, &slot->output);
                return slot;
              }) &
          tbb::make_filter<Slot*, void>(tbb::filter_mode::serial_in_order, [&](Slot* slot) {
            if (failed.load()) return;
            if (!slot->status.ok()) {
              first_error = slot->status;
              failed = true;
              return;
            }
            merge(slot->chunk, slot->output);
          }));
  return first_error;
}

}  // namespace graphslam::core::internal
