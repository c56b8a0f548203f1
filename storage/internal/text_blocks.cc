#include "storage/internal/text_blocks.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "storage/internal/text_reader.h"

namespace graphslam::storage::internal {
namespace {

// std::isspace in the "C" locale, as a table (the tokenizer's inner loop).
constexpr std::array<bool, 256> MakeSpaceTable() {
  std::array<bool, 256> table{};
  for (const char c : {' ', '\t', '\n', '\v', '\f', '\r'}) table[static_cast<unsigned char>(c)] = true;
  return table;
}
constexpr std::array<bool, 256> kSpace = MakeSpaceTable();

// a == b for short tokens, inline (std::string_view == calls memcmp).
inline bool SameBytes(std::string_view a, std::string_view b) {
  const size_t n = a.size();
  if (n != b.size()) return false;
  size_t i = 0;
  for (; i + 8 <= n; i += 8) {
    uint64_t x = 0, y = 0;
    std::memcpy(&x, a.data() + i, 8);
    std::memcpy(&y, b.data() + i, 8);
    if (x != y) return false;
  }
  for (; i < n; ++i)
    if (a[i] != b[i]) return false;
  return true;
}

// [-]digits with at most 15 digits: the integer is below 2^53, so the double
// is exact and equals what std::from_chars gives (correct rounding of an
// exactly representable value). Anything else: false (ParseDouble decides).
inline bool ParseSmallInteger(std::string_view token, double* value) {
  const bool negative = token[0] == '-';
  const size_t first = negative ? 1 : 0;
  if (token.size() <= first || token.size() - first > 15) return false;
  uint64_t magnitude = 0;
  for (size_t i = first; i < token.size(); ++i) {
    const unsigned digit = static_cast<unsigned char>(token[i]) - unsigned{'0'};
    if (digit > 9) return false;
    magnitude = magnitude * 10 + digit;
  }
  const auto exact = static_cast<double>(magnitude);
  *value = negative ? -exact : exact;
  return true;
}

}  // namespace

StatusOr<std::unique_ptr<TextBlockCutter>> TextBlockCutter::Open(const std::string& path,
                                                                 int64_t offset, int32_t line,
                                                                 int64_t block_bytes) {
  GS_CHECK(offset >= 0 && block_bytes > 0);
  std::unique_ptr<TextBlockCutter> cutter(new TextBlockCutter());
  cutter->path_ = path;
  GS_ASSIGN_OR_RETURN(cutter->file_, InputFile::Open(path, offset));
  cutter->offset_ = offset;
  cutter->line_ = line;
  cutter->block_bytes_ = block_bytes;
  return cutter;
}

bool TextBlockCutter::Next(TextBlock* block, Status* status) {
  block->lines.clear();
  block->status = Status::Ok();
  if (end_of_file_ && carry_.empty()) return false;
  block->text.assign(carry_);  // keeps the (pooled) block's capacity
  carry_.clear();
  // Read until the block holds a '\n' and at least block_bytes (or the end).
  while (!end_of_file_) {
    const size_t old = block->text.size();
    const auto want = static_cast<size_t>(block_bytes_);
    block->text.resize(old + want);
    Status read;
    const size_t got = file_->Read(block->text.data() + old, want, &read);
    block->text.resize(old + got);
    if (!read.ok()) {
      *status = read;
      return false;
    }
    if (got < want) end_of_file_ = true;
    const size_t newline = block->text.find('\n', old);
    // Until the first '\n', the block is one line (carry_ holds no '\n').
    if ((newline == std::string::npos ? block->text.size() : newline) > kMaxLineBytes) {
      *status = Status::Corruption(
          BaseName(path_) + ":" + std::to_string(line_ + 1) + ": line is longer than " +
          std::to_string(kMaxLineBytes) +
          " bytes; expected text records (a line of a supported format is < 1 KiB)");
      return false;
    }
    if (newline != std::string::npos) break;
  }
  if (!end_of_file_) {
    const size_t last = block->text.rfind('\n');
    carry_.assign(block->text, last + 1, std::string::npos);
    block->text.resize(last + 1);
  }
  if (block->text.empty()) return false;
  block->start_line = line_;
  const auto newlines =
      static_cast<int32_t>(std::count(block->text.begin(), block->text.end(), '\n'));
  const bool partial = block->text.back() != '\n';  // a last line without '\n'
  line_ += newlines + (partial ? 1 : 0);
  offset_ += static_cast<int64_t>(block->text.size());
  block->end_line = line_;
  block->end_offset = offset_;
  return true;
}

namespace {

// Splits [position, line_end) at white space into parsed's fields; false if
// the line is dropped (a comment, or a tag not in `only_tags`).
inline bool SplitFields(const char* position, const char* line_end,
                        const std::vector<std::string_view>& only_tags, TokenizedLine* parsed) {
  for (const char* p = position; p < line_end;) {
    while (p < line_end && kSpace[static_cast<unsigned char>(*p)]) ++p;
    if (p >= line_end) break;
    const char* token = p;
    while (p < line_end && !kSpace[static_cast<unsigned char>(*p)]) ++p;
    const std::string_view field(token, static_cast<size_t>(p - token));
    if (parsed->num_fields == 0) {
      if (field[0] == '#') return false;  // a comment
      if (!only_tags.empty() &&
          std::find(only_tags.begin(), only_tags.end(), field) == only_tags.end())
        return false;
    }
    if (parsed->num_fields < TokenizedLine::kMaxFields) {
      parsed->fields[parsed->num_fields] = field;
    } else {
      parsed->overflow.push_back(field);
    }
    ++parsed->num_fields;
  }
  return true;
}

// The previous kept line's conversions, per field: records of a log repeat
// most fields (the information, often the pose), and equal bytes convert
// to the same double, so a repeated token is not converted again.
struct ConversionMemo {
  std::string_view token[TokenizedLine::kMaxConverted];
  double value[TokenizedLine::kMaxConverted];
  bool converted[TokenizedLine::kMaxConverted] = {};
};

// Converts the fields after the tag that look like numbers into
// parsed->values, setting their bits in parsed->converted.
inline void ConvertFields(TokenizedLine* parsed, ConversionMemo* memo) {
  const int convertible = std::min(parsed->num_fields, TokenizedLine::kMaxConverted);
  for (int i = 1; i < convertible; ++i) {
    const std::string_view field = parsed->fields[i];
    // Only what looks like a number is tried (ids and tags are cheap to skip).
    const char c = field[0];
    if (!((c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.')) continue;
    if (SameBytes(field, memo->token[i])) {
      if (memo->converted[i]) {
        parsed->values[i] = memo->value[i];
        parsed->converted |= 1u << i;
      }
      continue;
    }
    double value = 0.0;
    const bool converted =
        (ParseSmallInteger(field, &value) || ParseDouble(field, &value)) && std::isfinite(value);
    memo->token[i] = field;
    memo->converted[i] = converted;
    memo->value[i] = value;
    if (converted) {
      parsed->values[i] = value;
      parsed->converted |= 1u << i;
    }
  }
}

}  // namespace

void TokenizeBlock(TextBlock* block, const std::vector<std::string_view>& only_tags) {
  block->lines.clear();
  // At most one entry per line of the block: no growth, no copies.
  if (block->end_line > block->start_line)
    block->lines.reserve(static_cast<size_t>(block->end_line - block->start_line));
  const char* position = block->text.data();
  const char* const end = position + block->text.size();
  int32_t line = block->start_line;
  ConversionMemo memo;
  bool reuse_last = false;  // block->lines.back() holds a dropped line: overwrite it
  while (position < end) {
    const auto* newline = static_cast<const char*>(std::memchr(position, '\n', end - position));
    const char* const line_end = newline != nullptr ? newline : end;
    ++line;
    // Filled in place (no copy of the ~420 B line into the vector).
    if (!reuse_last) block->lines.emplace_back();
    TokenizedLine& parsed = block->lines.back();
    parsed.num_fields = 0;
    parsed.converted = 0;
    parsed.overflow.clear();
    reuse_last = true;
    const bool keep = SplitFields(position, line_end, only_tags, &parsed);
    position = line_end + 1;
    if (!keep || parsed.num_fields == 0) continue;
    ConvertFields(&parsed, &memo);
    parsed.line = line;
    reuse_last = false;
  }
  if (reuse_last) block->lines.pop_back();
}

}  // namespace graphslam::storage::internal
