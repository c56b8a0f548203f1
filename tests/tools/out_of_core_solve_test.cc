// The pure parts of the out-of-core solve options: ParseMemorySize
// (tools/memory_size.h), ChunksInFlightForMemoryLimit and
// IngestBufferObservations (tools/out_of_core_solve.h).
#include "tools/out_of_core_solve.h"

#include <gtest/gtest.h>

#include "core/problem.h"
#include "tools/memory_size.h"

namespace graphslam::tools {
namespace {

TEST(ParseMemorySize, SuffixesArePowersOf1024) {
  EXPECT_EQ(*ParseMemorySize("1000"), 1000);
  EXPECT_EQ(*ParseMemorySize("64k"), 64 * 1024);
  EXPECT_EQ(*ParseMemorySize("512M"), int64_t{512} << 20);
  EXPECT_EQ(*ParseMemorySize("2G"), int64_t{2} << 30);
  EXPECT_EQ(*ParseMemorySize("2GiB"), int64_t{2} << 30);
  EXPECT_EQ(*ParseMemorySize("1.5g"), int64_t{3} << 29);
  EXPECT_EQ(*ParseMemorySize("1T"), int64_t{1} << 40);
}

TEST(ParseMemorySize, GarbageIsInvalidArgumentNamingTheText) {
  for (const char* text : {"", "lots", "-1G", "0", "2X", "G"}) {
    StatusOr<int64_t> parsed = ParseMemorySize(text);
    ASSERT_FALSE(parsed.ok()) << text;
    std::string quoted = "'";  // (built by append: GCC 12 warns -Wrestrict on "'" + string)
    quoted.append(text).push_back('\'');
    EXPECT_NE(parsed.status().ToString().find(quoted), std::string::npos);
  }
}

TEST(ChunksInFlight, FitsThePoseSystemAndChunksIntoTheBudget) {
  // No limit: the default.
  EXPECT_EQ(*ChunksInFlightForMemoryLimit(0, 1000, 100, 4096, 8), 8);
  // 1000 poses, 100 features: pose system 1450000 + 6400 bytes; chunks of
  // 1024 observations cost 524288 bytes each.
  const int64_t pose_system = 1000 * kPoseSystemBytesPerPose + 100 * kBytesPerFeature;
  const int64_t chunk = 1024 * kBytesPerObservationInFlight;
  EXPECT_EQ(*ChunksInFlightForMemoryLimit(pose_system + 3 * chunk, 1000, 100, 1024, 8), 3);
  EXPECT_EQ(*ChunksInFlightForMemoryLimit(pose_system + 3 * chunk + chunk - 1, 1000, 100, 1024, 8),
            3);
  EXPECT_EQ(*ChunksInFlightForMemoryLimit(pose_system + 100 * chunk, 1000, 100, 1024, 8), 8);
  EXPECT_EQ(*ChunksInFlightForMemoryLimit(pose_system + chunk, 1000, 100, 1024, 8), 1);
  StatusOr<int> too_small = ChunksInFlightForMemoryLimit(pose_system + chunk - 1, 1000, 100, 1024, 8);
  ASSERT_FALSE(too_small.ok());
  EXPECT_NE(too_small.status().ToString().find(std::to_string(pose_system + chunk)),
            std::string::npos)
      << too_small.status().ToString();
}

// Streaming mode keeps a step's candidates on disk: fewer bytes per feature,
// so the 10^8 solve (10^6 poses, 4.4*10^7 observed features) fits 4G with
// the default 8 chunks of 4096 observations in flight.
TEST(ChunksInFlight, StreamingModeCountsItsSmallerPerFeatureCost) {
  const int64_t poses = 1000, features = 100000;
  const int64_t chunk = 1024 * kBytesPerObservationInFlight;
  const int64_t streaming_system =
      poses * kPoseSystemBytesPerPose + features * kBytesPerFeatureStreaming;
  EXPECT_LT(kBytesPerFeatureStreaming, kBytesPerFeature);
  EXPECT_EQ(*ChunksInFlightForMemoryLimit(streaming_system + 2 * chunk, poses, features, 1024, 8,
                                          /*streaming=*/true),
            2);
  EXPECT_FALSE(ChunksInFlightForMemoryLimit(streaming_system + 2 * chunk, poses, features, 1024,
                                            8, /*streaming=*/false)
                   .ok());
  EXPECT_EQ(*ChunksInFlightForMemoryLimit(int64_t{4} << 30, 1000000, 43750683, 4096, 8,
                                          /*streaming=*/true),
            8);
}

TEST(IngestBuffer, AThirdOfTheBudgetInObservationsAtLeastOneChunk) {
  const int64_t record = static_cast<int64_t>(sizeof(core::Observation));
  EXPECT_EQ(IngestBufferObservations(int64_t{3} << 20, 10), (int64_t{3} << 20) / (3 * record));
  EXPECT_EQ(IngestBufferObservations(0, 10), (int64_t{1} << 30) / (3 * record));
  EXPECT_EQ(IngestBufferObservations(1000, 4096), 4096);
}

}  // namespace
}  // namespace graphslam::tools
