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
#include "storage/internal/text_reader.h"

namespace graphslam::storage {
namespace {

inline bool IsSpace(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r';
}

struct Block {
  std::string text;           // whole lines
  int64_t end_offset = 0;
  int32_t start_line = 0;     // lines before the block
  int32_t end_line = 0;
  std::vector<core::Observation> observations;
  Status status;
};

class BlockParser {
 public:
  BlockParser(const std::string& name, const internal::IdMap& poses,
              const internal::IdMap& features)
      : name_(name), poses_(poses), features_(features) {}

  void Parse(Block* block) const {
    const char* position = block->text.data();
    const char* const end = position + block->text.size();
    int32_t line = block->start_line;
    while (position < end) {
      const auto* newline = static_cast<const char*>(std::memchr(position, '\n', end - position));
      const char* line_end = newline != nullptr ? newline : end;
      ++line;
      Status status = ParseLine(std::string_view(position, line_end - position), line,
                                &block->observations);
      if (!status.ok()) {
        block->status = std::move(status);
        return;
      }
      position = line_end + 1;
    }
  }

 private:
  Status ParseLine(std::string_view text, int32_t line,
                   std::vector<core::Observation>* out) const {
    std::string_view fields[9];
    size_t count = 0;
    const char* position = text.data();
    const char* const end = position + text.size();
    while (position < end) {
      while (position < end && IsSpace(*position)) ++position;
      if (position >= end) break;
      const char* token = position;
      while (position < end && !IsSpace(*position)) ++position;
      if (count == 0) {
        // Only RB / XY lines matter; anything else is skipped unparsed.
        const std::string_view tag(token, static_cast<size_t>(position - token));
        if (tag != "RB" && tag != "XY") return Status::Ok();
      }
      if (count == 9) return Changed(line, "more than 8 fields");
      fields[count++] = std::string_view(token, static_cast<size_t>(position - token));
    }
    if (count == 0) return Status::Ok();
    if (count != 8) return Changed(line, std::to_string(count) + " fields");
    int64_t pose_id = 0, feature_id = 0;
    double values[5];
    if (!internal::ParseInt64(fields[1], &pose_id) || !internal::ParseInt64(fields[2], &feature_id))
      return Changed(line, "an id that is not an integer");
    for (int k = 0; k < 5; ++k)
      if (!internal::ParseDouble(fields[3 + k], &values[k]) || !std::isfinite(values[k]))
        return Changed(line, "a field that is not a finite number");
    core::Observation observation;
    observation.pose = poses_.Find(pose_id);
    observation.feature = features_.Find(feature_id);
    if (observation.pose < 0 || observation.feature < 0)
      return Changed(line, "pose " + std::to_string(pose_id) + " or feature " +
                               std::to_string(feature_id) + " unknown to the first pass");
    observation.kind = fields[0] == "RB" ? core::ObservationKind::kRangeBearing
                                         : core::ObservationKind::kPointXY;
    observation.z = Eigen::Vector2d(values[0], values[1]);
    observation.information = internal::SymmetricFromUpper2(values + 2);
    observation.line = line;
    out->push_back(observation);
    return Status::Ok();
  }

  Status Changed(int32_t line, const std::string& what) const {
    return internal::CorruptionAt(name_, line,
                                  what + " in an RB / XY record; the file changed since the "
                                         "first pass (rerun the ingest without --resume)");
  }

  const std::string& name_;
  const internal::IdMap& poses_;
  const internal::IdMap& features_;
};

struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};

}  // namespace

Status ReplayNativeLogObservations(const std::string& path, const std::vector<int64_t>& pose_ids,
                                   const std::vector<int64_t>& feature_ids,
                                   const NativeLogReplayOptions& options,
                                   const NativeLogBlockSink& sink) {
  GS_CHECK(options.block_bytes > 0 && options.blocks_in_flight > 0 && options.start_offset >= 0);
  std::unique_ptr<std::FILE, FileCloser> file(std::fopen(path.c_str(), "rb"));
  if (!file) return Status::IOError(path + ": open for reading: " + std::strerror(errno));
  if (options.start_offset > 0 &&
      fseeko(file.get(), static_cast<off_t>(options.start_offset), SEEK_SET) != 0)
    return Status::IOError(path + ": seek to byte " + std::to_string(options.start_offset) + ": " +
                           std::strerror(errno));
  internal::IdMap poses, features;
  poses.Build(pose_ids);
  features.Build(feature_ids);
  const std::string name = internal::BaseName(path);
  const BlockParser parser(name, poses, features);

  std::string carry;  // the start of a line that goes on in the next read
  bool end_of_file = false;
  int64_t offset = options.start_offset;
  int32_t line = options.start_line;
  Status read_failure;                // set by the first stage only
  Status sink_failure;                // set by the last stage only
  std::atomic<bool> failed{false};    // read by the first stage, set by both

  tbb::parallel_pipeline(
      static_cast<size_t>(options.blocks_in_flight),
      tbb::make_filter<void, Block*>(
          tbb::filter_mode::serial_in_order,
          [&](tbb::flow_control& control) -> Block* {
            if (failed || (end_of_file && carry.empty())) {
              control.stop();
              return nullptr;
            }
            auto block = std::make_unique<Block>();
            block->text = std::move(carry);
            carry.clear();
            // Read until the block holds a '\n' and at least block_bytes (or the end).
            while (!end_of_file) {
              const size_t old = block->text.size();
              const size_t want = static_cast<size_t>(options.block_bytes);
              block->text.resize(old + want);
              const size_t got = std::fread(block->text.data() + old, 1, want, file.get());
              block->text.resize(old + got);
              if (got < want) {
                if (std::ferror(file.get())) {
                  read_failure = Status::IOError(path + ": read error after byte " +
                                            std::to_string(offset + static_cast<int64_t>(old + got)));
                  failed = true;
                  control.stop();
                  return nullptr;
                }
                end_of_file = true;
              }
              if (block->text.find('\n', old) != std::string::npos) break;
            }
            if (!end_of_file) {
              const size_t last = block->text.rfind('\n');
              carry.assign(block->text, last + 1, std::string::npos);
              block->text.resize(last + 1);
            }
            block->start_line = line;
            const auto newlines =
                static_cast<int32_t>(std::count(block->text.begin(), block->text.end(), '\n'));
            // A last line without '\n' is a line too (std::getline).
            const bool partial = !block->text.empty() && block->text.back() != '\n';
            line += newlines + (partial ? 1 : 0);
            offset += static_cast<int64_t>(block->text.size());
            block->end_line = line;
            block->end_offset = offset;
            return block.release();
          }) &
          tbb::make_filter<Block*, Block*>(tbb::filter_mode::parallel,
                                           [&](Block* block) -> Block* {
                                             parser.Parse(block);
                                             block->text = std::string();
                                             return block;
                                           }) &
          tbb::make_filter<Block*, void>(tbb::filter_mode::serial_in_order, [&](Block* raw) {
            std::unique_ptr<Block> block(raw);
            if (failed) return;
            Status status = block->status;
            if (status.ok()) {
              NativeLogObservationBlock view;
              view.observations = block->observations.data();
              view.size = block->observations.size();
              view.end_offset = block->end_offset;
              view.end_line = block->end_line;
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
