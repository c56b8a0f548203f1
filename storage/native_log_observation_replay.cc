#include "storage/native_log_observation_replay.h"

#include <tbb/parallel_pipeline.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string_view>
#include <utility>

#include "storage/internal/id_map.h"
#include "storage/internal/text_blocks.h"
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

// Observations of the RB / XY lines of one tokenized block.
class BlockParser {
 public:
  BlockParser(const std::string& name, const internal::IdMap& poses,
              const internal::IdMap& features)
      : name_(name), poses_(poses), features_(features) {}

  Status Parse(const internal::TextBlock& block, std::vector<core::Observation>* out) const {
    out->reserve(out->size() + block.lines.size());  // every kept line is RB / XY
    for (const internal::TokenizedLine& line : block.lines) {
      if (line.num_fields != 8) return Changed(line.line, std::to_string(line.num_fields) + " fields");
      int64_t pose_id = 0, feature_id = 0;
      if (!internal::ParseInt64(line.fields[1], &pose_id) ||
          !internal::ParseInt64(line.fields[2], &feature_id))
        return Changed(line.line, "an id that is not an integer");
      // Fields 3..7 converted by TokenizeBlock (the same ParseDouble).
      if ((line.converted & 0xF8u) != 0xF8u)
        return Changed(line.line, "a field that is not a finite number");
      core::Observation observation;
      observation.pose = poses_.Find(pose_id);
      observation.feature = features_.Find(feature_id);
      if (observation.pose < 0 || observation.feature < 0)
        return Changed(line.line, "pose " + std::to_string(pose_id) + " or feature " +
                                      std::to_string(feature_id) + " unknown to the first pass");
      observation.kind = line.fields[0] == "RB" ? core::ObservationKind::kRangeBearing
                                                : core::ObservationKind::kPointXY;
      observation.z = Eigen::Vector2d(line.values[3], line.values[4]);
      observation.information = internal::SymmetricFromUpper2(line.values + 5);
      observation.line = line.line;
      out->push_back(observation);
    }
    return Status::Ok();
  }

 private:
  Status Changed(int32_t line, const std::string& what) const {
    return internal::CorruptionAt(name_, line,
                                  what + " in an RB / XY record; the file changed since the "
                                         "first pass (rerun the ingest without --resume)");
  }

  const std::string& name_;
  const internal::IdMap& poses_;
  const internal::IdMap& features_;
};

struct Block {
  internal::TextBlock text;
  std::vector<core::Observation> observations;
  Status status;
};

}  // namespace

Status ReplayNativeLogObservations(const std::string& path, const std::vector<int64_t>& pose_ids,
                                   const std::vector<int64_t>& feature_ids,
                                   const NativeLogReplayOptions& options,
                                   const NativeLogBlockSink& sink) {
  GS_CHECK(options.block_bytes > 0 && options.blocks_in_flight > 0 && options.start_offset >= 0);
  GS_ASSIGN_OR_RETURN(std::unique_ptr<internal::TextBlockCutter> cutter,
                      internal::TextBlockCutter::Open(path, options.start_offset,
                                                      options.start_line, options.block_bytes));
  internal::IdMap poses, features;
  poses.Build(pose_ids);
  features.Build(feature_ids);
  const std::string name = internal::BaseName(path);
  const BlockParser parser(name, poses, features);
  const std::vector<std::string_view> tags = {"RB", "XY"};
  internal::BlockPool<Block> pool;  // blocks_in_flight blocks, reused

  Status read_failure;              // set by the first stage only
  Status sink_failure;              // set by the last stage only
  std::atomic<bool> failed{false};  // read by the first stage, set by both
  tbb::parallel_pipeline(
      static_cast<size_t>(options.blocks_in_flight),
      tbb::make_filter<void, Block*>(
          tbb::filter_mode::serial_in_order,
          [&](tbb::flow_control& control) -> Block* {
            std::unique_ptr<Block> block = pool.Take();
            block->observations.clear();
            if (failed || !cutter->Next(&block->text, &read_failure)) {
              if (!read_failure.ok()) failed = true;
              control.stop();
              return nullptr;
            }
            return block.release();
          }) &
          tbb::make_filter<Block*, Block*>(tbb::filter_mode::parallel,
                                           [&](Block* block) -> Block* {
                                             internal::TokenizeBlock(&block->text, tags);
                                             block->status =
                                                 parser.Parse(block->text, &block->observations);
                                             return block;
                                           }) &
          tbb::make_filter<Block*, void>(tbb::filter_mode::serial_in_order, [&](Block* raw) {
            std::unique_ptr<Block> block(raw);
            struct Recycle {
              internal::BlockPool<Block>* pool;
              std::unique_ptr<Block>* block;
              ~Recycle() { pool->Give(std::move(*block)); }
            } recycle{&pool, &block};
            if (failed) return;
            Status status = block->status;
            if (status.ok()) {
              NativeLogObservationBlock view;
              view.observations = block->observations.data();
              view.size = block->observations.size();
              view.end_offset = block->text.end_offset;
              view.end_line = block->text.end_line;
              status = sink(view);
            }
            if (!status.ok()) {
              sink_failure = std::move(status);
              failed = true;
            }
          }));
  return !sink_failure.ok() ? sink_failure : read_failure;
}

}  // namespace graphslam::storage
