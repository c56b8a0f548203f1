// storage/internal/text_blocks.h: TokenizeBlock's fields and converted
// values equal a plain split and ParseDouble (std::from_chars) bit for bit,
// with its shortcuts (exact small integers, a repeated token reusing the
// previous line's conversion) exercised: integers of 1..17 digits, signs,
// -0, '+', repeated and alternating tokens, non-numbers, non-finite values,
// comment lines and more fields than a TokenizedLine holds directly.
#include "storage/internal/text_blocks.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <algorithm>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "storage/internal/text_reader.h"

namespace graphslam::storage::internal {
namespace {

uint64_t Bits(double value) {
  uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  return bits;
}

std::vector<std::string> Split(const std::string& line) {
  std::istringstream stream(line);
  std::vector<std::string> fields;
  for (std::string field; stream >> field;) fields.push_back(field);
  return fields;
}

std::string RandomToken(std::mt19937_64& random) {
  static const std::vector<std::string> fixed = {
      "0", "-0", "+0", "+5", "-", "+", ".", "-.5", "1e5", "0x10", "007", "-007",
      "999999999999999", "1000000000000000", "9007199254740993", "-9007199254740993",
      "12345678901234567", "99.999999999999986", "2500", "1e400", "-1e400", "nan", "inf",
      "1.5.2", "12a", "-12-", "4154581", "7.8720046639378722", "8.1643119943156876e-17"};
  switch (random() % 4) {
    case 0:
      return fixed[random() % fixed.size()];
    case 1: {  // an integer of 1..17 digits, maybe signed
      std::string token = random() % 3 == 0 ? "-" : "";
      const int digits = 1 + static_cast<int>(random() % 17);
      for (int d = 0; d < digits; ++d) token.push_back(static_cast<char>('0' + random() % 10));
      return token;
    }
    case 2: {  // a random double as %.17g
      std::uniform_real_distribution<double> uniform(-1e6, 1e6);
      return FormatDouble(uniform(random));
    }
    default:  // a repeat-prone token
      return random() % 2 == 0 ? "2500" : "99.999999999999986";
  }
}

TEST(TextBlocks, TokenizeBlockEqualsASplitAndFromCharsOnRandomRecords) {
  std::mt19937_64 random(2026);
  TextBlock block;
  std::vector<std::string> lines;
  for (int i = 0; i < 20000; ++i) {
    std::string line;
    if (random() % 50 == 0) {
      line = "# a comment 1 2 3";
    } else if (random() % 50 == 0) {
      line = "  \t ";
    } else {
      line = random() % 2 == 0 ? "RB" : "XY";
      const int fields = 1 + static_cast<int>(random() % 20);  // beyond kMaxFields too
      for (int f = 0; f < fields; ++f) line += (random() % 5 == 0 ? " \t " : " ") + RandomToken(random);
    }
    lines.push_back(line);
    block.text += line + (random() % 20 == 0 ? "\r\n" : "\n");
  }
  block.start_line = 7;
  block.end_line = 7 + static_cast<int32_t>(lines.size());
  TokenizeBlock(&block);

  size_t kept = 0;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::vector<std::string> fields = Split(lines[i]);
    if (fields.empty() || fields[0][0] == '#') continue;
    ASSERT_LT(kept, block.lines.size());
    const TokenizedLine& line = block.lines[kept++];
    ASSERT_EQ(line.line, static_cast<int32_t>(7 + i + 1)) << lines[i];
    ASSERT_EQ(line.num_fields, static_cast<int32_t>(fields.size())) << lines[i];
    for (size_t f = 0; f < fields.size(); ++f) {
      const std::string_view got = f < TokenizedLine::kMaxFields
                                       ? line.fields[f]
                                       : line.overflow[f - TokenizedLine::kMaxFields];
      ASSERT_EQ(got, fields[f]) << "line " << i << " field " << f;
      if (f == 0 || f >= static_cast<size_t>(TokenizedLine::kMaxConverted)) continue;
      double expected = 0.0;
      const char c = fields[f][0];
      const bool looks_numeric = (c >= '0' && c <= '9') || c == '-' || c == '+' || c == '.';
      const bool converts =
          looks_numeric && ParseDouble(fields[f], &expected) && std::isfinite(expected);
      ASSERT_EQ(((line.converted >> f) & 1u) != 0, converts) << "'" << fields[f] << "'";
      if (converts) {
        ASSERT_EQ(Bits(line.values[f]), Bits(expected)) << "'" << fields[f] << "'";
      }
      // Marked an integer exactly when it is [-]digits of <= 15 digits;
      // then the value is the integer from_chars reads (LineReader::Id).
      const std::string& token = fields[f];
      const size_t sign = token[0] == '-' ? 1 : 0;
      const bool integer = token.size() > sign && token.size() - sign <= 15 &&
                           token.find_first_not_of("0123456789", sign) == std::string::npos;
      ASSERT_EQ(((line.integer >> f) & 1u) != 0, integer) << "'" << token << "'";
      if (integer) {
        int64_t id = 0;
        ASSERT_TRUE(ParseInt64(token, &id)) << token;
        ASSERT_EQ(static_cast<int64_t>(line.values[f]), id) << token;
      }
    }
  }
  EXPECT_EQ(kept, block.lines.size());
}

TEST(TextBlocks, TokenizeBlockKeepsOnlyTheGivenTags) {
  TextBlock block;
  block.text = "POSE 1 0.5\nRB 1 2 3 4 100 0 100\n# RB 9\nXY 1 2 3 4 100 0 100\nGPS 1 2 3";
  TokenizeBlock(&block, {"RB", "XY"});
  ASSERT_EQ(block.lines.size(), 2u);
  EXPECT_EQ(block.lines[0].line, 2);
  EXPECT_EQ(block.lines[0].fields[0], "RB");
  EXPECT_EQ(block.lines[1].line, 4);
  EXPECT_EQ(block.lines[1].fields[0], "XY");
  EXPECT_EQ(block.lines[1].values[5], 100.0);
}

// The cutter's line counts (the numbers in every message) on text with runs
// of empty lines longer than 255 x 16 bytes, long lines, '\r\n', and a last
// line without '\n', cut into blocks of several sizes.
TEST(TextBlocks, CutterCountsEveryLineWhateverTheBlockSize) {
  std::mt19937_64 random(7);
  std::string text;
  int32_t lines = 0;
  for (int i = 0; i < 600; ++i) {
    const int kind = random() % 10 == 0 ? 0 : 1 + static_cast<int>(random() % 3);
    const int length = kind == 0 ? 0 : kind == 1 ? static_cast<int>(random() % 40)
                                                 : static_cast<int>(random() % 9000);
    const int repeat = kind == 0 ? static_cast<int>(random() % 6000) : 1;
    for (int r = 0; r < repeat; ++r) {
      for (int c = 0; c < length; ++c) text.push_back(static_cast<char>('a' + random() % 26));
      text += random() % 3 == 0 ? "\r\n" : "\n";
      ++lines;
    }
  }
  text += "last line";
  ++lines;
  const auto dir = std::filesystem::temp_directory_path() /
                   ("graphslam_text_blocks_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "lines.txt").string();
  std::ofstream(path, std::ios::binary) << text;
  for (const int64_t block_bytes :
       {int64_t{64}, int64_t{4093}, int64_t{1} << 16, int64_t{1} << 20}) {
    StatusOr<std::unique_ptr<TextBlockCutter>> cutter =
        TextBlockCutter::Open(path, 0, 0, block_bytes);
    ASSERT_TRUE(cutter.ok()) << cutter.status().ToString();
    TextBlock block;
    Status status;
    int32_t counted = 0;
    int64_t bytes = 0;
    while ((*cutter)->Next(&block, &status)) {
      ASSERT_EQ(block.start_line, counted);
      counted += static_cast<int32_t>(std::count(block.text.begin(), block.text.end(), '\n')) +
                 (block.text.back() != '\n' ? 1 : 0);
      bytes += static_cast<int64_t>(block.text.size());
      ASSERT_EQ(block.end_line, counted) << block_bytes;
      ASSERT_EQ(block.end_offset, bytes);
    }
    ASSERT_TRUE(status.ok()) << status.ToString();
    EXPECT_EQ(counted, lines) << block_bytes;
    EXPECT_EQ(bytes, static_cast<int64_t>(text.size()));
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::storage::internal
