// storage/native_log_counts.h: the counts trailer is read from a plain log's
// last line and from a zstd log's last frame (without decompressing the
// records' frame before it), a log without one is NotFound, and the trailer
// is a comment: the log reads back as its records plus that line.
#include "storage/native_log_counts.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>
#include <string>

#include "storage/compressed_file.h"
#include "storage/env.h"

namespace graphslam::storage {
namespace {

class NativeLogCountsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("graphslam_log_counts_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    // Records that compress poorly enough to span far more than the tail
    // the trailer is looked for in.
    std::mt19937 random(11);
    records_ = "GRAPHSLAM_LOG 1\n";
    while (records_.size() < (size_t{1} << 20))
      records_ += "RB 1 " + std::to_string(random() % 1000000) + " " +
                  std::to_string(random()) + " 0.5 100 0 400\n";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  void WritePlain(const std::string& path, const std::string& text) const {
    std::ofstream(path, std::ios::binary) << text;
  }
  // The records in one zstd frame, then `trailer` (if any) in a frame of its own.
  void WriteZstd(const std::string& path, const std::string& trailer) const {
    auto file = Env::Default()->NewWritableFile(path);
    ASSERT_TRUE(file.ok());
    {
      ZstdWriter records(file->get(), 3);
      ASSERT_TRUE(records.Append(records_).ok());
      ASSERT_TRUE(records.Finish().ok());
    }
    if (!trailer.empty()) {
      ZstdWriter last(file->get(), 3);
      ASSERT_TRUE(last.Append(trailer).ok());
      ASSERT_TRUE(last.Finish().ok());
    }
    ASSERT_TRUE((*file)->Close().ok());
  }

  std::filesystem::path dir_;
  std::string records_;
};

TEST_F(NativeLogCountsTest, ThePlainLogsLastLineGivesTheCounts) {
  const NativeLogCounts written{1000000, 43750683, 399899840};
  const std::string line = NativeLogCountsLine(written);
  EXPECT_EQ(line, "# counts: poses 1000000 features 43750683 observations 399899840\n");
  WritePlain(Path("log.graphslam"), records_ + line);
  const StatusOr<NativeLogCounts> read = ReadNativeLogCounts(Path("log.graphslam"));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->poses, 1000000);
  EXPECT_EQ(read->features, 43750683);
  EXPECT_EQ(read->observations, 399899840);
}

TEST_F(NativeLogCountsTest, TheIdRangeIsOptional) {
  const std::string line = NativeLogCountsLine({10, 20, 30, 1000020});
  EXPECT_EQ(line, "# counts: poses 10 features 20 observations 30 feature_ids 1000020\n");
  WritePlain(Path("with"), records_ + line);
  const StatusOr<NativeLogCounts> with = ReadNativeLogCounts(Path("with"));
  ASSERT_TRUE(with.ok()) << with.status().ToString();
  EXPECT_EQ(with->features, 20);
  EXPECT_EQ(with->feature_id_end, 1000020);
  // A trailer without it (older logs): not known.
  WritePlain(Path("without"), records_ + NativeLogCountsLine({10, 20, 30}));
  const StatusOr<NativeLogCounts> without = ReadNativeLogCounts(Path("without"));
  ASSERT_TRUE(without.ok()) << without.status().ToString();
  EXPECT_EQ(without->feature_id_end, -1);
  // Anything else after the observations is no trailer.
  WritePlain(Path("bad"), records_ + "# counts: poses 1 features 2 observations 3 feature_ids\n");
  EXPECT_EQ(ReadNativeLogCounts(Path("bad")).status().code(), Status::Code::kNotFound);
  WritePlain(Path("neg"), records_ + "# counts: poses 1 features 2 observations 3 feature_ids -4\n");
  EXPECT_EQ(ReadNativeLogCounts(Path("neg")).status().code(), Status::Code::kNotFound);
}

TEST_F(NativeLogCountsTest, TheZstdLogsLastFrameGivesTheCountsAndReadsBackAsAComment) {
  const std::string line = NativeLogCountsLine({7, 8, 9});
  WriteZstd(Path("log.graphslam.zst"), line);
  ASSERT_GT(std::filesystem::file_size(Path("log.graphslam.zst")), 4096u * 4);
  const StatusOr<NativeLogCounts> read = ReadNativeLogCounts(Path("log.graphslam.zst"));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->poses, 7);
  EXPECT_EQ(read->features, 8);
  EXPECT_EQ(read->observations, 9);
  // Every reader sees the records and then the trailer's comment line.
  auto input = InputFile::Open(Path("log.graphslam.zst"));
  ASSERT_TRUE(input.ok());
  std::string all(records_.size() + line.size() + 1, '\0');
  Status status;
  all.resize((*input)->Read(all.data(), all.size(), &status));
  ASSERT_TRUE(status.ok()) << status.ToString();
  EXPECT_EQ(all, records_ + line);
}

TEST_F(NativeLogCountsTest, ALogWithoutATrailerIsNotFound) {
  WritePlain(Path("plain"), records_);
  EXPECT_EQ(ReadNativeLogCounts(Path("plain")).status().code(), Status::Code::kNotFound);
  WriteZstd(Path("zstd"), "");
  EXPECT_EQ(ReadNativeLogCounts(Path("zstd")).status().code(), Status::Code::kNotFound);
  // A counts line that is not the last line, or is malformed, is no trailer.
  WritePlain(Path("inside"), NativeLogCountsLine({1, 2, 3}) + records_);
  EXPECT_EQ(ReadNativeLogCounts(Path("inside")).status().code(), Status::Code::kNotFound);
  WritePlain(Path("bad"), records_ + "# counts: poses 1 features x observations 3\n");
  EXPECT_EQ(ReadNativeLogCounts(Path("bad")).status().code(), Status::Code::kNotFound);
  WritePlain(Path("negative"), records_ + "# counts: poses 1 features -2 observations 3\n");
  EXPECT_EQ(ReadNativeLogCounts(Path("negative")).status().code(), Status::Code::kNotFound);
  EXPECT_EQ(ReadNativeLogCounts(Path("missing")).status().code(), Status::Code::kIOError);
}

}  // namespace
}  // namespace graphslam::storage
