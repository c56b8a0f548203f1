// Spill frames (partition/ingest/spill_frames.h): observations round-trip bit for
// bit; every kind of damage is Corruption naming the file and the frame's
// byte offset; frame boundaries are found from the headers alone.
#include "partition/ingest/spill_frames.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "tests/testing/random_observations.h"

namespace graphslam::partition {
namespace {

using graphslam::testing::ExpectBitwiseEqual;
using graphslam::testing::RandomObservations;

// What a bucket run of the simulator looks like: constant information and
// kind, poses and lines rising, features and measurements varied.
std::vector<core::Observation> SimulatorRun(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<core::Observation> run(20000);
  for (size_t i = 0; i < run.size(); ++i) {
    run[i].pose = static_cast<int32_t>(i / 40);
    run[i].feature = static_cast<int32_t>(rng() % 50000);
    run[i].z = {8.0 + uniform(rng), uniform(rng)};
    run[i].information << 99.999999999999986, 0, 0, 2500;
    run[i].line = static_cast<int32_t>(3 + i + i / 40);
  }
  return run;
}

class SpillFramesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            ("graphslam_spill_frames_" + std::string(info->name()) + "_" +
             std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
    path_ = (root_ / "bucket_000000.bin").string();
  }
  void TearDown() override { std::filesystem::remove_all(root_); }


  // Appends one frame per run and returns the byte offset where each frame starts.
  std::vector<int64_t> WriteFrames(const std::vector<core::Observation>& all,
                                   const std::vector<size_t>& runs) {
    SpillFrameEncoder encoder(1);
    std::ofstream out(path_, std::ios::binary);
    std::vector<int64_t> starts;
    size_t begin = 0;
    int64_t offset = 0;
    for (const size_t n : runs) {
      std::vector<char> frame;
      EXPECT_TRUE(encoder.Encode(all.data() + begin, n, &frame).ok());
      out.write(frame.data(), static_cast<std::streamsize>(frame.size()));
      starts.push_back(offset);
      offset += static_cast<int64_t>(frame.size());
      begin += n;
    }
    starts.push_back(offset);
    return starts;
  }

  Status Read(std::vector<core::Observation>* out) const {
    StatusOr<std::unique_ptr<storage::ReadableFile>> file =
        storage::Env::Default()->NewReadableFile(path_);
    EXPECT_TRUE(file.ok()) << file.status().ToString();
    if (!file.ok()) return file.status();
    SpillFrameDecoder decoder;
    return decoder.ReadFile(path_, file.value().get(), out);
  }

  std::string Bytes() const {
    std::ifstream in(path_, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  void SetBytes(const std::string& bytes) const {
    std::ofstream(path_, std::ios::binary | std::ios::trunc) << bytes;
  }

  std::filesystem::path root_;
  std::string path_;
};

TEST_F(SpillFramesTest, ObservationsRoundTripBitForBit) {
  const std::vector<core::Observation> all = RandomObservations(3000, 1);
  WriteFrames(all, {1, 0, 1999, 1000});
  std::vector<core::Observation> read;
  ASSERT_TRUE(Read(&read).ok());
  ASSERT_EQ(read.size(), all.size());
  for (size_t i = 0; i < all.size(); ++i) ExpectBitwiseEqual(read[i], all[i]);
}

TEST_F(SpillFramesTest, TheSimulatorsObservationsShrinkAboutThreefold) {
  const std::vector<core::Observation> run = SimulatorRun(2);
  std::vector<char> frame;
  SpillFrameEncoder encoder(1);
  ASSERT_TRUE(encoder.Encode(run.data(), run.size(), &frame).ok());
  const double per_observation = static_cast<double>(frame.size()) / run.size();
  EXPECT_LT(per_observation, 72.0 / 2.5);  // the raw struct is 72 bytes
  EXPECT_GT(per_observation, 16.0);        // the two measurements are noise
}

TEST_F(SpillFramesTest, FramesOfAnyLevelReadBackBitForBitFromOneFile) {
  // A resumed ingest appends frames of its own default level to bucket files
  // an older run wrote at another: the decoder needs no level.
  const std::vector<core::Observation> all = RandomObservations(4000, 3);
  std::ofstream out(path_, std::ios::binary);
  size_t begin = 0;
  for (const int level : {1, kSpillFrameZstdLevel, 3, -5}) {
    SpillFrameEncoder encoder(level);
    std::vector<char> frame;
    ASSERT_TRUE(encoder.Encode(all.data() + begin, 1000, &frame).ok()) << "level " << level;
    out.write(frame.data(), static_cast<std::streamsize>(frame.size()));
    begin += 1000;
  }
  out.close();
  std::vector<core::Observation> read;
  const Status status = Read(&read);
  ASSERT_TRUE(status.ok()) << status.ToString();
  ASSERT_EQ(read.size(), all.size());
  for (size_t i = 0; i < all.size(); ++i) ExpectBitwiseEqual(read[i], all[i]);
}

TEST_F(SpillFramesTest, TheDefaultLevelStillShrinksTheSimulatorsRunsTwofold) {
  // kSpillFrameZstdLevel trades some size for speed; the columns (constant
  // information and kind, slowly rising poses and lines) still compress.
  const std::vector<core::Observation> run = SimulatorRun(4);
  std::vector<char> frame;
  SpillFrameEncoder encoder(kSpillFrameZstdLevel);
  ASSERT_TRUE(encoder.Encode(run.data(), run.size(), &frame).ok());
  const double per_observation = static_cast<double>(frame.size()) / run.size();
  EXPECT_LT(per_observation, 72.0 / 2.0);  // the raw struct is 72 bytes
  EXPECT_GT(per_observation, 16.0);        // the two measurements are noise
}

TEST_F(SpillFramesTest, DamageIsCorruptionNamingTheFileAndTheFramesOffset) {
  const std::vector<core::Observation> all = RandomObservations(600, 3);
  const std::vector<int64_t> starts = WriteFrames(all, {200, 300, 100});
  const std::string good = Bytes();
  struct Case {
    const char* what;
    std::string bytes;
    int64_t offset;
    const char* message;
  };
  std::vector<Case> cases;
  std::string flipped = good;
  flipped[static_cast<size_t>(starts[1]) + kSpillFrameHeaderBytes + 5] ^= 0x20;
  cases.push_back({"payload byte flipped", flipped, starts[1], "CRC mismatch"});
  std::string count = good;
  count[static_cast<size_t>(starts[2]) + 4] ^= 0x01;
  cases.push_back({"count changed", count, starts[2], "CRC mismatch"});
  std::string magic = good;
  magic[static_cast<size_t>(starts[1])] = 'X';
  cases.push_back({"bad magic", magic, starts[1], "bad magic"});
  cases.push_back({"truncated payload", good.substr(0, static_cast<size_t>(starts[3]) - 7),
                   starts[2], "truncated"});
  cases.push_back({"truncated header", good.substr(0, static_cast<size_t>(starts[1]) + 9),
                   starts[1], "truncated header"});
  std::string length = good;
  length[static_cast<size_t>(starts[0]) + 10] = 0x7f;  // payload_bytes beyond the file
  cases.push_back({"bad length", length, starts[0], "truncated"});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    SetBytes(c.bytes);
    std::vector<core::Observation> read;
    const Status status = Read(&read);
    ASSERT_FALSE(status.ok());
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_NE(status.message().find(path_ + ": spill frame at byte " + std::to_string(c.offset) +
                                    ": " + c.message),
              std::string::npos)
        << status.ToString();
  }
}

TEST_F(SpillFramesTest, BoundariesComeFromTheHeadersAndACountInsideAFrameIsCorruption) {
  const std::vector<core::Observation> all = RandomObservations(600, 4);
  const std::vector<int64_t> starts = WriteFrames(all, {200, 300, 100});
  EXPECT_EQ(*SpillFrameBoundary(path_, 0), 0);
  EXPECT_EQ(*SpillFrameBoundary(path_, 200), starts[1]);
  EXPECT_EQ(*SpillFrameBoundary(path_, 500), starts[2]);
  EXPECT_EQ(*SpillFrameBoundary(path_, 600), starts[3]);
  const StatusOr<int64_t> inside = SpillFrameBoundary(path_, 250);
  ASSERT_FALSE(inside.ok());
  EXPECT_NE(inside.status().message().find("end inside a frame"), std::string::npos)
      << inside.status().ToString();
  const StatusOr<int64_t> beyond = SpillFrameBoundary(path_, 700);
  ASSERT_FALSE(beyond.ok());
  EXPECT_NE(beyond.status().message().find(path_ + ": spill frame at byte " +
                                           std::to_string(starts[3]) + ": the file ends after 600"),
            std::string::npos)
      << beyond.status().ToString();
  // A torn last frame (a kill mid-append) still has its boundary before it.
  SetBytes(Bytes().substr(0, static_cast<size_t>(starts[3]) - 10));
  EXPECT_EQ(*SpillFrameBoundary(path_, 500), starts[2]);
  EXPECT_FALSE(SpillFrameBoundary(path_, 600).ok());
  // No file holds zero observations.
  std::filesystem::remove(path_);
  EXPECT_EQ(*SpillFrameBoundary(path_, 0), 0);
  EXPECT_FALSE(SpillFrameBoundary(path_, 1).ok());
}

}  // namespace
}  // namespace graphslam::partition
