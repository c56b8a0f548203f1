// storage/internal/text_reader.h: the block-buffered LineReader gives the
// lines std::getline gives (lines straddling the 1 MiB blocks, a last line
// without '\n', CR LF, blank and comment lines), its messages are unchanged,
// and the to_chars-based "%.17g" formatting is byte-identical to snprintf's
// (problem.graphslam files written before and after must not differ).
#include "storage/internal/text_reader.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace graphslam::storage::internal {
namespace {

std::string Snprintf17(double value) {
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  return buffer;
}

TEST(TextReader, FormatDoubleEqualsSnprintfOnRandomBitPatternsAndSpecialValues) {
  std::mt19937_64 random(12345);
  std::vector<double> values = {0.0,
                                -0.0,
                                1.0,
                                -1.5,
                                0.1,
                                1e-300,
                                1e300,
                                123456789012345678.0,
                                std::numeric_limits<double>::denorm_min(),
                                std::numeric_limits<double>::min(),
                                std::numeric_limits<double>::max(),
                                std::numeric_limits<double>::epsilon(),
                                std::numeric_limits<double>::infinity(),
                                -std::numeric_limits<double>::infinity()};
  for (int i = 0; i < 200000; ++i) {
    const uint64_t bits = random();
    double value;
    std::memcpy(&value, &bits, sizeof(value));
    if (std::isnan(value)) continue;
    values.push_back(value);
  }
  std::uniform_real_distribution<double> uniform(-1000.0, 1000.0);
  for (int i = 0; i < 200000; ++i) values.push_back(uniform(random));
  for (int i = 0; i < 1000; ++i) values.push_back(std::ldexp(uniform(random), i % 2100 - 1075));
  for (const double value : values) {
    ASSERT_EQ(FormatDouble(value), Snprintf17(value)) << "bits of " << Snprintf17(value);
    std::string line = "X";
    AppendField(&line, value);
    ASSERT_EQ(line, "X " + Snprintf17(value));
  }
  for (const int64_t id : {int64_t{0}, int64_t{-7}, int64_t{123456789012345},
                           std::numeric_limits<int64_t>::min(),
                           std::numeric_limits<int64_t>::max()}) {
    std::string line;
    AppendField(&line, id);
    EXPECT_EQ(line, std::to_string(id));
  }
}

class LineReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = (std::filesystem::temp_directory_path() /
             ("graphslam_line_reader_" + std::to_string(::getpid()) + ".txt"))
                .string();
  }
  void TearDown() override { std::filesystem::remove(path_); }

  void Write(const std::string& text) {
    std::ofstream out(path_, std::ios::binary);
    out << text;
  }

  // What the reader returns: one string per record, fields joined by '|',
  // with the line number.
  std::vector<std::string> ReadAll() {
    StatusOr<std::unique_ptr<LineReader>> reader = LineReader::Open(path_);
    EXPECT_TRUE(reader.ok()) << reader.status().ToString();
    std::vector<std::string> records;
    while ((*reader)->Next()) {
      std::string record = std::to_string((*reader)->line_number()) + ":";
      for (const std::string_view field : (*reader)->fields()) {
        record += std::string(field);
        record += '|';
      }
      records.push_back(record);
    }
    EXPECT_TRUE((*reader)->status().ok());
    return records;
  }

  // The same through std::getline and std::istringstream (the old reader).
  static std::vector<std::string> Reference(const std::string& text) {
    std::istringstream in(text);
    std::string line;
    std::vector<std::string> records;
    int number = 0;
    while (std::getline(in, line)) {
      ++number;
      std::istringstream tokens(line);
      std::string token, record = std::to_string(number) + ":";
      bool any = false;
      bool comment = false;
      while (tokens >> token) {
        if (!any && token[0] == '#') comment = true;
        any = true;
        record += token + '|';
      }
      if (any && !comment) records.push_back(record);
    }
    return records;
  }

  std::string path_;
};

TEST_F(LineReaderTest, GivesTheLinesOfGetlineAcrossBlockBoundaries) {
  std::mt19937 random(7);
  std::string text;
  // ~3 MiB: lines of up to 3000 characters straddle the 1 MiB blocks; a line
  // of almost a block too (longer than kMaxLineBytes = one block is an
  // error: tests/storage/input_limits_test.cc).
  while (text.size() < 3u * 1024 * 1024) {
    const int kind = static_cast<int>(random() % 10);
    if (kind == 0) {
      text += "\n";
    } else if (kind == 1) {
      text += "  # a comment 1 2 3\n";
    } else if (kind == 2) {
      text += "RB 1 2 3.5 -0.25 100 0 400\r\n";
    } else {
      const int fields = 1 + static_cast<int>(random() % 600);
      for (int f = 0; f < fields; ++f) {
        if (f > 0) text.push_back(random() % 3 == 0 ? '\t' : ' ');
        text.append(std::to_string(random()));
      }
      text += "\n";
    }
  }
  text += "LONG";
  text += std::string(1000000, 'x');
  text += " tail\nLAST 1 2";  // no final '\n'
  Write(text);
  const std::vector<std::string> read = ReadAll();
  const std::vector<std::string> reference = Reference(text);
  ASSERT_EQ(read.size(), reference.size());
  for (size_t i = 0; i < read.size(); ++i) ASSERT_EQ(read[i], reference[i]) << "record " << i;
  EXPECT_EQ(read.back().substr(read.back().find(':')), ":LAST|1|2|");
}

TEST_F(LineReaderTest, EmptyFileAndFinalNewlineGiveNoExtraRecord) {
  Write("");
  EXPECT_TRUE(ReadAll().empty());
  Write("A 1\n\n");
  EXPECT_EQ(ReadAll(), std::vector<std::string>{"1:A|1|"});
}

TEST_F(LineReaderTest, FieldErrorsNameTheFileLineTagFieldAndExpectation) {
  Write("RB 1 x nan 2\n");
  StatusOr<std::unique_ptr<LineReader>> reader = LineReader::Open(path_);
  ASSERT_TRUE(reader.ok());
  ASSERT_TRUE((*reader)->Next());
  const std::string name = BaseName(path_);
  StatusOr<int64_t> id = (*reader)->Id(2, "feature id");
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.status().ToString(),
            "Corruption: " + name + ":1: RB field 3 (feature id) is 'x'; expected an integer id");
  StatusOr<double> number = (*reader)->Double(2, "range");
  EXPECT_EQ(number.status().ToString(),
            "Corruption: " + name + ":1: RB field 3 (range) is 'x'; expected a number");
  number = (*reader)->Double(3, "bearing");
  EXPECT_EQ(number.status().ToString(),
            "Corruption: " + name + ":1: RB field 4 (bearing) is 'nan'; expected a finite number");
  number = (*reader)->Double(4, "bearing");
  ASSERT_TRUE(number.ok());
  EXPECT_EQ(*number, 2.0);
}

}  // namespace
}  // namespace graphslam::storage::internal
