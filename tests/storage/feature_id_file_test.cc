// FeatureIdFile (storage/feature_id_file.h): parked ids come back bit for bit
// and their memory is released; a damaged file is Corruption naming the file
// and the record's offset; the destructor removes the scratch file.
#include "storage/feature_id_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

namespace graphslam::storage {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("graphslam_ids_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

TEST(FeatureIdFile, ParkedIdsComeBackBitForBitAndTheirMemoryIsReleased) {
  std::mt19937_64 rng(3);
  std::vector<int64_t> ids;
  for (int i = 0; i < 140000; ++i) ids.push_back(static_cast<int64_t>(rng()));  // 3 records
  ids[7] = -1;
  ids[8] = std::numeric_limits<int64_t>::min();
  const std::vector<int64_t> expected = ids;
  const std::string path = TempPath("a.bin");
  {
    FeatureIdFile file(Env::Default(), path);
    ASSERT_TRUE(file.Park(&ids).ok());
    EXPECT_TRUE(ids.empty());
    EXPECT_EQ(ids.capacity(), 0u) << "memory not released";
    EXPECT_EQ(std::filesystem::file_size(path), 24 + 3 * (9 + 12) + 8 * expected.size() + 25);
    ASSERT_TRUE(file.Restore(&ids).ok());
    EXPECT_EQ(ids, expected);
  }
  EXPECT_FALSE(std::filesystem::exists(path)) << "scratch file left behind";
}

TEST(FeatureIdFile, DamagedFileIsCorruptionNamingTheFileAndOffset) {
  std::vector<int64_t> ids(100);
  for (int i = 0; i < 100; ++i) ids[i] = 1000 + i;
  const std::string path = TempPath("b.bin");
  FeatureIdFile file(Env::Default(), path);
  ASSERT_TRUE(file.Park(&ids).ok());
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  bytes[24 + 9 + 12 + 8 * 50] ^= 0x04;
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  Status status = file.Restore(&ids);
  EXPECT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_NE(status.message().find(path + ": offset 24: record checksum mismatch"),
            std::string::npos)
      << status.ToString();
  std::filesystem::remove(path);
  status = file.Restore(&ids);
  EXPECT_TRUE(status.IsNotFound()) << status.ToString();
  EXPECT_NE(status.message().find(path), std::string::npos) << status.ToString();
}

}  // namespace
}  // namespace graphslam::storage
