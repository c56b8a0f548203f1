// storage/compressed_file.h: a zstd stream reads back as the bytes written,
// from any offset; a plain file reads the same through the same interface;
// truncated and corrupted streams are Corruption errors naming the file and
// the offsets.
#include "storage/compressed_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>

#include "storage/env.h"

namespace graphslam::storage {
namespace {

class CompressedFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("graphslam_zstd_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    // Text-like, compressible, several MiB (spans many zstd blocks and reads).
    std::mt19937 random(7);
    while (text_.size() < (size_t{3} << 20))
      text_ += "RB " + std::to_string(random() % 100000) + " " +
               std::to_string(random() % 1000000) + " 1.25 -0.5 100 0 400\n";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  void WriteZstd(const std::string& path, int workers) const {
    auto file = Env::Default()->NewWritableFile(path);
    ASSERT_TRUE(file.ok());
    ZstdWriter writer(file->get(), 3, workers);
    for (size_t at = 0; at < text_.size(); at += 100000)
      ASSERT_TRUE(writer.Append(std::string_view(text_).substr(at, 100000)).ok());
    ASSERT_TRUE(writer.Finish().ok());
    ASSERT_TRUE((*file)->Close().ok());
    EXPECT_EQ(writer.bytes_in(), static_cast<int64_t>(text_.size()));
    EXPECT_LT(writer.bytes_out(), writer.bytes_in() / 2);
  }
  static std::string ReadAll(InputFile* input, Status* status) {
    std::string all;
    char buffer[65536];
    while (true) {
      const size_t got = input->Read(buffer, sizeof(buffer), status);
      all.append(buffer, got);
      if (got < sizeof(buffer)) break;
    }
    return all;
  }
  static std::string Bytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  static void Put(const std::string& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary) << bytes;
  }

  std::filesystem::path dir_;
  std::string text_;
};

TEST_F(CompressedFileTest, ZstdReadsBackTheWrittenBytesFromAnyOffset) {
  for (const int workers : {0, 1}) {
    const std::string path = Path("log" + std::to_string(workers) + ".zst");
    WriteZstd(path, workers);
    EXPECT_TRUE(IsZstdFile(path));
    for (const int64_t offset : {int64_t{0}, int64_t{1}, int64_t{1234567},
                                 static_cast<int64_t>(text_.size())}) {
      auto input = InputFile::Open(path, offset);
      ASSERT_TRUE(input.ok()) << input.status().ToString();
      EXPECT_TRUE((*input)->compressed());
      Status status;
      EXPECT_TRUE(ReadAll(input->get(), &status) == text_.substr(static_cast<size_t>(offset)));
      EXPECT_TRUE(status.ok()) << status.ToString();
    }
  }
}

TEST_F(CompressedFileTest, PlainFileReadsThroughTheSameInterface) {
  Put(Path("plain.txt"), text_);
  EXPECT_FALSE(IsZstdFile(Path("plain.txt")));
  auto input = InputFile::Open(Path("plain.txt"), 99);
  ASSERT_TRUE(input.ok());
  EXPECT_FALSE((*input)->compressed());
  Status status;
  EXPECT_TRUE(ReadAll(input->get(), &status) == text_.substr(99));
  EXPECT_TRUE(status.ok());
  EXPECT_EQ(InputFile::Open(Path("missing")).status().code(), Status::Code::kNotFound);
}

TEST_F(CompressedFileTest, TruncatedStreamIsCorruptionWithFileAndOffsets) {
  WriteZstd(Path("full.zst"), 0);
  const std::string bytes = Bytes(Path("full.zst"));
  Put(Path("cut.zst"), bytes.substr(0, bytes.size() / 2));
  auto input = InputFile::Open(Path("cut.zst"));
  ASSERT_TRUE(input.ok());
  Status status;
  const std::string read = ReadAll(input->get(), &status);
  EXPECT_EQ(status.code(), Status::Code::kCorruption);
  EXPECT_NE(status.message().find(Path("cut.zst") + ": truncated zstd stream"), std::string::npos)
      << status.ToString();
  EXPECT_NE(status.message().find("compressed offset " + std::to_string(bytes.size() / 2)),
            std::string::npos)
      << status.ToString();
  EXPECT_NE(status.message().find("decompressed offset " + std::to_string(read.size())),
            std::string::npos)
      << status.ToString();
  EXPECT_TRUE(read == text_.substr(0, read.size()));  // what came before is right
  // A resume point past the end of what is there is an error too.
  EXPECT_EQ(InputFile::Open(Path("cut.zst"), static_cast<int64_t>(text_.size())).status().code(),
            Status::Code::kCorruption);
}

TEST_F(CompressedFileTest, FlippedByteIsCorruptionNamingTheFile) {
  WriteZstd(Path("full.zst"), 0);
  std::string bytes = Bytes(Path("full.zst"));
  const size_t flip = bytes.size() / 3;
  bytes[flip] = static_cast<char>(bytes[flip] ^ 0x5a);
  Put(Path("flipped.zst"), bytes);
  auto input = InputFile::Open(Path("flipped.zst"));
  ASSERT_TRUE(input.ok());
  Status status;
  const std::string read = ReadAll(input->get(), &status);
  EXPECT_EQ(status.code(), Status::Code::kCorruption) << status.ToString();
  EXPECT_NE(status.message().find(Path("flipped.zst") + ": corrupt zstd data"), std::string::npos)
      << status.ToString();
  EXPECT_NE(status.message().find("compressed bytes before offset"), std::string::npos);
  EXPECT_LT(read.size(), text_.size());
}

}  // namespace
}  // namespace graphslam::storage
