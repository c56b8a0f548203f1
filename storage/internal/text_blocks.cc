#include "storage/internal/text_blocks.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

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

// The '\n' bytes of [begin, end): the cutter's serial stage counts every
// byte of the input. std::count compiled to a byte loop (~3 instructions a
// byte); with SSE2, 16 bytes are compared at once and the matches summed in
// byte lanes, emptied (_mm_sad_epu8) before a lane can overflow.
inline int64_t CountNewlines(const char* begin, const char* end) {
  int64_t count = 0;
#if defined(__SSE2__)
  const __m128i newline = _mm_set1_epi8('\n');
  while (end - begin >= 16) {
    __m128i lanes = _mm_setzero_si128();  // per byte: matches so far, <= 255
    for (int i = 0; i < 255 && end - begin >= 16; ++i, begin += 16) {
      const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(begin));
      lanes = _mm_sub_epi8(lanes, _mm_cmpeq_epi8(v, newline));  // a match is -1
    }
    const __m128i sums = _mm_sad_epu8(lanes, _mm_setzero_si128());
    count += _mm_cvtsi128_si64(sums) + _mm_cvtsi128_si64(_mm_unpackhi_epi64(sums, sums));
  }
#endif
  for (; begin < end; ++begin) count += *begin == '\n';
  return count;
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
  const auto newlines = static_cast<int32_t>(
      CountNewlines(block->text.data(), block->text.data() + block->text.size()));
  const bool partial = block->text.back() != '\n';  // a last line without '\n'
  line_ += newlines + (partial ? 1 : 0);
  offset_ += static_cast<int64_t>(block->text.size());
  block->end_line = line_;
  block->end_offset = offset_;
  return true;
}

namespace {

// Appends one field to parsed; false if the line is dropped (a comment, or
// a tag not in `only_tags`).
inline bool AddField(std::string_view field, const std::vector<std::string_view>& only_tags,
                     TokenizedLine* parsed) {
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
  return true;
}

#if defined(__SSE2__)
// Bit i set: byte i of the 16 at `bytes` is white space (kSpace: ' ' or
// '\t'..'\r', i.e. byte - 9 <= 4 unsigned).
inline uint32_t SpaceMask16(const char* bytes) {
  const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(bytes));
  const __m128i blank = _mm_cmpeq_epi8(v, _mm_set1_epi8(' '));
  const __m128i shifted = _mm_sub_epi8(v, _mm_set1_epi8(9));
  const __m128i control = _mm_cmpeq_epi8(_mm_min_epu8(shifted, _mm_set1_epi8(4)), shifted);
  return static_cast<uint32_t>(_mm_movemask_epi8(_mm_or_si128(blank, control)));
}
#endif

// Splits [position, line_end) at white space into parsed's fields; false if
// the line is dropped (AddField). With SSE2, 16 bytes are classified at once
// and the fields found from the bit mask's transitions (a ~90-byte record
// has ~16 of them; the byte loop below branched on every byte): loads never
// reach past `text_end` (a window there is copied into a blank-padded one).
inline bool SplitFields(const char* position, const char* line_end, const char* text_end,
                        const std::vector<std::string_view>& only_tags, TokenizedLine* parsed) {
#if defined(__SSE2__)
  const char* token = nullptr;  // the field being read, if any
  for (const char* window = position; window < line_end; window += 16) {
    uint32_t space;
    if (text_end - window >= 16) {
      space = SpaceMask16(window);
    } else {
      char padded[16];
      std::memset(padded, ' ', sizeof(padded));
      std::memcpy(padded, window, static_cast<size_t>(text_end - window));
      space = SpaceMask16(padded);
    }
    // Bytes past the line count as white space.
    if (line_end - window < 16) space |= 0xFFFFu << (line_end - window);
    uint32_t live = 0xFFFFu;  // positions of this window not yet passed
    while (true) {
      if (token == nullptr) {
        const uint32_t starts = ~space & live;
        if (starts == 0) break;
        const int start = __builtin_ctz(starts);
        token = window + start;
        live &= ~((2u << start) - 1);
      }
      const uint32_t ends = space & live;
      if (ends == 0) break;
      const int stop = __builtin_ctz(ends);
      if (!AddField(std::string_view(token, static_cast<size_t>(window + stop - token)),
                    only_tags, parsed))
        return false;
      token = nullptr;
      live &= ~((2u << stop) - 1);
    }
  }
  if (token != nullptr)
    return AddField(std::string_view(token, static_cast<size_t>(line_end - token)), only_tags,
                    parsed);
  return true;
#else
  static_cast<void>(text_end);
  for (const char* p = position; p < line_end;) {
    while (p < line_end && kSpace[static_cast<unsigned char>(*p)]) ++p;
    if (p >= line_end) break;
    const char* token = p;
    while (p < line_end && !kSpace[static_cast<unsigned char>(*p)]) ++p;
    if (!AddField(std::string_view(token, static_cast<size_t>(p - token)), only_tags, parsed))
      return false;
  }
  return true;
#endif
}

// The previous kept line's conversions, per field: records of a log repeat
// most fields (the information, often the pose), and equal bytes convert
// to the same double, so a repeated token is not converted again.
struct ConversionMemo {
  std::string_view token[TokenizedLine::kMaxConverted];
  double value[TokenizedLine::kMaxConverted];
  bool converted[TokenizedLine::kMaxConverted] = {};
  bool integer[TokenizedLine::kMaxConverted] = {};
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
        if (memo->integer[i]) parsed->integer |= 1u << i;
      }
      continue;
    }
    double value = 0.0;
    const bool integer = ParseSmallInteger(field, &value);
    const bool converted = (integer || ParseDouble(field, &value)) && std::isfinite(value);
    memo->token[i] = field;
    memo->converted[i] = converted;
    memo->integer[i] = integer;
    memo->value[i] = value;
    if (converted) {
      parsed->values[i] = value;
      parsed->converted |= 1u << i;
      if (integer) parsed->integer |= 1u << i;
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
    parsed.integer = 0;
    parsed.overflow.clear();
    reuse_last = true;
    const bool keep = SplitFields(position, line_end, end, only_tags, &parsed);
    position = line_end + 1;
    if (!keep || parsed.num_fields == 0) continue;
    ConvertFields(&parsed, &memo);
    parsed.line = line;
    reuse_last = false;
  }
  if (reuse_last) block->lines.pop_back();
}

}  // namespace graphslam::storage::internal
