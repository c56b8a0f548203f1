// Text input cut into blocks of whole lines, for readers that tokenize and
// convert numbers in parallel (TBB) and interpret the lines in order: the
// native log's reader (native_log_reader.cc; the ingest's pass 2 no longer
// reads text: it replays pass 1's observations, partition/ingest/replay_frames.h).
//
//   TextBlockCutter::Next   serial: the next ~block_bytes of whole lines, with
//                           the number of lines before them and the byte
//                           offset after them (a resume point)
//   TokenizeBlock           parallel-safe: splits every line of a block into
//                           fields (the C locale's whitespace, as LineReader),
//                           skipping blank and comment lines, and converts the
//                           first kMaxConverted fields to doubles where they
//                           are numbers (LineReader::Double uses them), with
//                           the bits of std::from_chars: [-]digits of <= 15
//                           digits directly (and marked as integers, for
//                           the ids), and a token byte-equal to the
//                           previous line's in that field by reuse
//   BlockPool               blocks recycled from a pipeline's last stage to
//                           its first
//
// A last line without '\n' is a line (std::getline); line numbers count every
// line, blank and comment lines included, as LineReader does.
//
// THREAD SAFETY: a cutter is used by one thread at a time; TokenizeBlock
// touches only its block. ALLOCATION: the block's text and its lines.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"
#include "storage/compressed_file.h"

namespace graphslam::storage::internal {

struct TokenizedLine {
  // 12: the longest native records (CONTROL, CONTROL_INFO, ODOM). A line is
  // ~330 B; a 1 MiB block holds ~13 000 of them, so the size counts.
  static constexpr int kMaxFields = 12;
  static constexpr int kMaxConverted = 12;
  int32_t line = 0;       // 1-based line number
  int32_t num_fields = 0;  // all fields (views beyond kMaxFields in `overflow`)
  uint32_t converted = 0;  // bit i: values[i] holds field i as a finite double
  // bit i (a subset of `converted`): field i is [-]digits, at most 15 of
  // them, so values[i] is that integer exactly and LineReader::Id takes it
  // from there instead of converting the field again in the serial stage.
  uint32_t integer = 0;
  std::string_view fields[kMaxFields];
  double values[kMaxConverted];
  std::vector<std::string_view> overflow;  // fields kMaxFields.. of long lines
};

struct TextBlock {
  std::string text;  // whole lines
  int32_t start_line = 0;  // lines before the block
  int32_t end_line = 0;    // lines up to and including the block
  int64_t end_offset = 0;  // byte offset after the block
  std::vector<TokenizedLine> lines;  // TokenizeBlock's output
  Status status;                     // for the stages of a pipeline
};

class TextBlockCutter {
 public:
  // NotFound / IOError naming the path. `offset` must be a line start and
  // `line` the number of lines before it. A zstd-compressed file is read
  // decompressed (storage/compressed_file.h): offsets count decompressed bytes.
  static StatusOr<std::unique_ptr<TextBlockCutter>> Open(const std::string& path, int64_t offset,
                                                         int32_t line, int64_t block_bytes);
  // Fills *block (text, start_line, end_line, end_offset; lines cleared);
  // false at the end of the file (then *status may hold a read error).
  bool Next(TextBlock* block, Status* status);

 private:
  std::string path_;
  std::unique_ptr<InputFile> file_;
  int64_t block_bytes_ = 0;
  int64_t offset_ = 0;
  int32_t line_ = 0;
  std::string carry_;
  bool end_of_file_ = false;
};

// Blocks handed back by a pipeline's last stage to its first: a read reuses
// kBlocksInFlight blocks (their text, line and output buffers keep their
// capacity) instead of allocating ~5 MB per MiB of input. Fresh multi-MB
// buffers per block cost page faults, and freed in other threads' malloc
// arenas at varying sizes they stayed resident (peak RSS +100 MB at 10^7).
// THREAD SAFETY: Take and Give may be called from any threads.
template <typename Block>
class BlockPool {
 public:
  std::unique_ptr<Block> Take() {
    std::lock_guard<std::mutex> lock(mutex_);
    if (free_.empty()) return std::make_unique<Block>();
    std::unique_ptr<Block> block = std::move(free_.back());
    free_.pop_back();
    return block;
  }
  void Give(std::unique_ptr<Block> block) {
    std::lock_guard<std::mutex> lock(mutex_);
    free_.push_back(std::move(block));
  }

 private:
  std::mutex mutex_;
  std::vector<std::unique_ptr<Block>> free_;
};

// `only_tags`: when not empty, lines whose first field is not one of them are
// dropped unconverted (the replay wants RB / XY only).
void TokenizeBlock(TextBlock* block, const std::vector<std::string_view>& only_tags = {});

}  // namespace graphslam::storage::internal
