// Replay frames (partition/ingest/replay_frames.h): pass 1's observations come back
// bit for bit, in order, from any replay position (a resume); segments hold
// exactly S observations; damage and a missing segment are Corruption naming
// the segment (and the frame's byte offset); released segments are deleted.
#include "partition/ingest/replay_frames.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "tests/testing/random_observations.h"

namespace graphslam::partition {
namespace {

using graphslam::testing::ExpectBitwiseEqual;
using graphslam::testing::RandomObservations;

class ReplayFramesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            ("graphslam_replay_frames_" + std::string(info->name()) + "_" +
             std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
    options_.frame_observations = 7;
    options_.frames_per_segment = 3;  // S = 21
  }
  void TearDown() override { std::filesystem::remove_all(root_); }

  void Write(const std::vector<core::Observation>& observations, int64_t* bytes = nullptr) {
    ReplayFrameWriter writer(root_.string(), options_);
    for (const core::Observation& o : observations) ASSERT_TRUE(writer.Add(o).ok());
    ASSERT_TRUE(writer.Finish().ok());
    EXPECT_EQ(writer.observations(), static_cast<int64_t>(observations.size()));
    if (bytes != nullptr) *bytes = writer.bytes_written();
  }

  // The replay from `start`: its observations, and the blocks' end positions.
  Status Read(int64_t start, int64_t total, std::vector<core::Observation>* out,
              std::vector<int64_t>* ends, int64_t* bytes_read = nullptr) {
    return ReplayFrames(root_.string(), options_, start, total, bytes_read)(
        [&](const ObservationBlock& block) {
          out->insert(out->end(), block.observations, block.observations + block.size);
          ends->push_back(block.end_offset);
          return Status::Ok();
        });
  }

  std::filesystem::path root_;
  ReplayFrameOptions options_;
};

TEST_F(ReplayFramesTest, RoundTripsFromEveryPositionInFrameSteps) {
  const std::vector<core::Observation> input = RandomObservations(100, 3);  // 4 full segments + 16
  int64_t written = 0;
  Write(input, &written);
  for (int64_t segment = 0; segment < 5; ++segment)
    EXPECT_TRUE(std::filesystem::exists(ReplaySegmentPath(root_.string(), segment))) << segment;
  EXPECT_FALSE(std::filesystem::exists(ReplaySegmentPath(root_.string(), 5)));
  // Every frame boundary is a resume position (0, 7, 14, 21, 28, ...).
  for (int64_t start = 0; start <= 100; start += 7) {
    SCOPED_TRACE("start " + std::to_string(start));
    std::vector<core::Observation> out;
    std::vector<int64_t> ends;
    int64_t read = 0;
    ASSERT_TRUE(Read(start, 100, &out, &ends, &read).ok());
    ASSERT_EQ(out.size(), static_cast<size_t>(100 - start));
    for (size_t i = 0; i < out.size(); ++i) ExpectBitwiseEqual(out[i], input[start + i]);
    // One block per frame, ending at the frame boundaries, the last at 100.
    for (size_t b = 0; b < ends.size(); ++b)
      EXPECT_EQ(ends[b], std::min<int64_t>(100, (start / 7 + 1 + static_cast<int64_t>(b)) * 7));
    if (start == 0) {
      EXPECT_EQ(read, written);
    }
  }
}

TEST_F(ReplayFramesTest, ReleaseDeletesTheSegmentsBeforeAPosition) {
  Write(RandomObservations(100, 5));
  ReleaseReplaySegmentsBefore(root_.string(), options_, 50);  // segments 0, 1 end by 42
  EXPECT_FALSE(std::filesystem::exists(ReplaySegmentPath(root_.string(), 0)));
  EXPECT_FALSE(std::filesystem::exists(ReplaySegmentPath(root_.string(), 1)));
  EXPECT_TRUE(std::filesystem::exists(ReplaySegmentPath(root_.string(), 2)));
  std::vector<core::Observation> out;
  std::vector<int64_t> ends;
  ASSERT_TRUE(Read(49, 100, &out, &ends).ok());  // a resume after the release still works
  EXPECT_EQ(out.size(), 51u);
  // Reading a released segment is Corruption naming it.
  const Status status = Read(21, 100, &out, &ends);
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_NE(status.message().find(ReplaySegmentPath(root_.string(), 1) + ": missing"),
            std::string::npos)
      << status.ToString();
  ReleaseReplaySegmentsBefore(root_.string(), options_, 105);  // all five
  EXPECT_TRUE(std::filesystem::is_empty(root_));
}

TEST_F(ReplayFramesTest, DamageIsCorruptionNamingTheSegmentAndFrameOffset) {
  Write(RandomObservations(60, 7));
  const std::string path = ReplaySegmentPath(root_.string(), 1);
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // The second frame of segment 1: its offset from the first frame's header.
  uint32_t payload = 0;
  std::memcpy(&payload, bytes.data() + 8, 4);
  const size_t second = kSpillFrameHeaderBytes + payload;
  bytes[second + kSpillFrameHeaderBytes + 2] ^= 0x01;
  std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  std::vector<core::Observation> out;
  std::vector<int64_t> ends;
  Status status = Read(0, 60, &out, &ends);
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_NE(status.message().find(path + ": spill frame at byte " + std::to_string(second) +
                                  ": CRC mismatch"),
            std::string::npos)
      << status.ToString();
  EXPECT_EQ(out.size(), 28u);  // everything before the damaged frame was delivered

  // A segment cut short (a total larger than was written).
  std::filesystem::resize_file(path, second);
  out.clear();
  status = Read(21, 60, &out, &ends);
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_NE(status.message().find(path + ": spill frame at byte " + std::to_string(second)),
            std::string::npos)
      << status.ToString();
}

}  // namespace
}  // namespace graphslam::partition
