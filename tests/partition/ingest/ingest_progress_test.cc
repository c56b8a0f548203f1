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

// pass1.bin, read in 1 MiB blocks: the FeatureIndex of more than one block
// comes back exactly (the ids are checked, not kept); a flipped byte in the
// ids, a truncated file and a missing one are reported.
TEST_F(IngestProgressTest, Pass1RecordGivesBackTheIndexAndChecksTheIds) {
  Pass1Record record;
  record.pose_ids = {10, 20, 30};
  for (int32_t f = 0; f < 300000; ++f) {  // 2.4 MB of ids, 1.2 MB of counts
    record.feature_ids.push_back(int64_t{7} * f + 5);
    record.counts.push_back(f % 9 + 1);
    record.first_pose.push_back(f % 3);
  }
  record.observations = 1234567;
  const std::string pass1 = (dir_ / kPass1RecordName).string();
  ASSERT_TRUE(WritePass1Record(storage::Env::Default(), pass1, record).ok());
  StatusOr<Pass1Record> read = ReadPass1Record(pass1);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->counts, record.counts);
  EXPECT_EQ(read->first_pose, record.first_pose);
  EXPECT_EQ(read->observations, 1234567);
  EXPECT_TRUE(read->pose_ids.empty() && read->feature_ids.empty());

  std::string bytes;
  {
    std::ifstream in(pass1, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  std::string flipped = bytes;
  flipped[40 + 3 * 8 + 8 * 200000] ^= 1;  // feature 200000's id, in the second block of ids
  std::ofstream(pass1, std::ios::binary | std::ios::trunc) << flipped;
  read = ReadPass1Record(pass1);
  ASSERT_FALSE(read.ok());
  EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
  EXPECT_THAT(read.status().message(), HasSubstr("crc mismatch"));
  std::ofstream(pass1, std::ios::binary | std::ios::trunc) << bytes.substr(0, bytes.size() - 8);
  read = ReadPass1Record(pass1);
  ASSERT_FALSE(read.ok());
  EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
  fs::remove(pass1);
  EXPECT_TRUE(ReadPass1Record(pass1).status().IsNotFound());
}

}  // namespace
}  // namespace graphslam::partition
