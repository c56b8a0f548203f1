// Tests of partition/ingest/ingest_progress.h's record (docs/formats/ingest_progress.md,
// version 4): it round-trips; an edited value or a removed checksum is
// Corruption naming the file (so `ingest --resume` starts afresh instead of
// resuming from a wrong position); the input is identified by size and
// CRC32C, so a record of a replaced input of the same size is another ingest.
#include "partition/ingest/ingest_progress.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <string>

namespace graphslam::partition {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class IngestProgressTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ingest_progress_test_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    path_ = (dir_ / kIngestProgressName).string();
    progress_.input = "in.graphslam";
    progress_.input_bytes = 4096;
    progress_.input_crc32c = 0x1234abcd;
    progress_.chunk_observations = 100;
    progress_.buffer_observations = 1000;
    progress_.stage = "chunks";
    progress_.chunks_durable = 17;
    progress_.spill.bucket_observations = {3, 4};
    ASSERT_TRUE(WriteIngestProgress(storage::Env::Default(), path_, progress_).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string ReadText() const {
    std::ifstream in(path_);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

  fs::path dir_;
  std::string path_;
  IngestProgress progress_;
};

TEST_F(IngestProgressTest, RoundTripsWithTheInputsCrc) {
  StatusOr<IngestProgress> read = ReadIngestProgress(path_);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_TRUE(read->SameIngest(progress_));
  EXPECT_EQ(read->input_crc32c, 0x1234abcdu);
  EXPECT_EQ(read->chunks_durable, 17);
  IngestProgress replaced = progress_;
  replaced.input_crc32c ^= 1;  // same path, size (and whatever mtime): another input
  EXPECT_FALSE(read->SameIngest(replaced));
}

TEST_F(IngestProgressTest, EditedRecordIsCorruption) {
  std::string text = ReadText();
  const size_t at = text.find("\"chunks_durable\": 17");
  ASSERT_NE(at, std::string::npos);
  text[at + 19] = '9';  // 17 -> 19: more chunks than are durable
  std::ofstream(path_, std::ios::trunc) << text;
  StatusOr<IngestProgress> read = ReadIngestProgress(path_);
  ASSERT_FALSE(read.ok());
  EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
  EXPECT_THAT(read.status().message(), HasSubstr(path_));
}

TEST_F(IngestProgressTest, RemovedChecksumIsCorruption) {
  nlohmann::json json = nlohmann::json::parse(ReadText());
  json.erase("checksum");
  std::ofstream(path_, std::ios::trunc) << json.dump(1);
  EXPECT_TRUE(ReadIngestProgress(path_).status().IsCorruption());
}

}  // namespace
}  // namespace graphslam::partition
