// Tests of the observation chunk format (docs/formats/observation_chunk.md):
// CRC32C vectors, bit-exact round trips, and faults made on purpose:
// flipped bytes in header, payload and CRC, truncations, bad lengths,
// injected I/O errors, and the dropped-byte counts of non-paranoid reads.
#include <gtest/gtest.h>
#include <unistd.h>

#include <bit>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <utility>
#include <vector>

#include "storage/chunk_format.h"
#include "storage/chunk_reader.h"
#include "storage/chunk_writer.h"
#include "storage/crc32c.h"
#include "storage/env.h"

namespace graphslam::storage {
namespace {

namespace format = chunk_format;
using Operation = FaultInjectionEnv::Operation;

// ---------------------------------------------------------------- helpers

std::string Hex32(uint32_t value) {
  char buffer[16];
  std::snprintf(buffer, sizeof(buffer), "0x%08" PRIx32, value);
  return buffer;
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

void Spit(const std::string& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << contents;
}

void PutFixed32At(std::string* data, size_t offset, uint32_t value) {
  for (int i = 0; i < 4; ++i) (*data)[offset + i] = static_cast<char>((value >> (8 * i)) & 0xFF);
}

// A chunk with `num_features` ascending, gapped features and random
// observations; doubles include -0.0, a subnormal and huge values so that
// "bit-exact" means something.
core::ObservationChunk MakeChunk(int64_t index, int num_features, int max_per_feature,
                                 uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> gap(1, 5);
  std::uniform_int_distribution<int> per_feature(0, max_per_feature);
  std::uniform_int_distribution<int> pose(0, 100000);
  std::normal_distribution<double> normal(0.0, 10.0);
  const double specials[] = {-0.0, 4.9406564584124654e-324, 1e308, -1e-300, 0.1};
  core::ObservationChunk chunk;
  chunk.index = index;
  chunk.feature_begin.push_back(0);
  int32_t feature = 0;
  for (int k = 0; k < num_features; ++k) {
    feature += gap(random);
    chunk.features.push_back(feature);
    // Every tenth feature may have no observation at all; the others at least one.
    const int count = k % 10 == 9 ? per_feature(random) : 1 + per_feature(random) % max_per_feature;
    for (int i = 0; i < count; ++i) {
      core::Observation o;
      o.pose = pose(random);
      o.feature = feature;
      o.kind = random() % 2 ? core::ObservationKind::kPointXY : core::ObservationKind::kRangeBearing;
      o.z = {normal(random), normal(random)};
      o.information << normal(random), normal(random), normal(random), normal(random);
      if (random() % 7 == 0) o.z[random() % 2] = specials[random() % 5];
      if (random() % 7 == 0) o.information.data()[random() % 4] = specials[random() % 5];
      o.line = static_cast<int32_t>(random() % 1000000);
      chunk.observations.push_back(o);
    }
    chunk.feature_begin.push_back(static_cast<int64_t>(chunk.observations.size()));
  }
  return chunk;
}

bool SameBits(double a, double b) { return std::bit_cast<uint64_t>(a) == std::bit_cast<uint64_t>(b); }

void ExpectBitExact(const core::ObservationChunk& expected, const core::ObservationChunk& actual) {
  EXPECT_EQ(expected.index, actual.index);
  ASSERT_EQ(expected.features, actual.features);
  ASSERT_EQ(expected.feature_begin, actual.feature_begin);
  ASSERT_EQ(expected.observations.size(), actual.observations.size());
  for (size_t i = 0; i < expected.observations.size(); ++i) {
    const core::Observation& e = expected.observations[i];
    const core::Observation& a = actual.observations[i];
    ASSERT_EQ(e.pose, a.pose) << "observation " << i;
    ASSERT_EQ(e.feature, a.feature) << "observation " << i;
    ASSERT_EQ(e.kind, a.kind) << "observation " << i;
    ASSERT_EQ(e.line, a.line) << "observation " << i;
    for (int j = 0; j < 2; ++j) ASSERT_TRUE(SameBits(e.z[j], a.z[j])) << "observation " << i;
    for (int j = 0; j < 4; ++j) {
      ASSERT_TRUE(SameBits(e.information.data()[j], a.information.data()[j])) << "observation " << i;
    }
  }
}

// The chunk without the features in slots [begin, end): what a non-paranoid
// read returns after dropping the block that held them.
core::ObservationChunk WithoutSlots(const core::ObservationChunk& chunk, int64_t begin,
                                    int64_t end) {
  core::ObservationChunk result;
  result.index = chunk.index;
  result.feature_begin.push_back(0);
  for (int64_t k = 0; k < chunk.num_features(); ++k) {
    if (k >= begin && k < end) continue;
    result.features.push_back(chunk.features[k]);
    for (int64_t o = chunk.feature_begin[k]; o < chunk.feature_begin[k + 1]; ++o) {
      result.observations.push_back(chunk.observations[o]);
    }
    result.feature_begin.push_back(static_cast<int64_t>(result.observations.size()));
  }
  return result;
}

// One framed record as found in a file.
struct Frame {
  size_t offset;
  uint32_t length;
  uint8_t type;
  size_t end() const { return offset + format::kRecordHeaderSize + length; }
};

std::vector<Frame> Frames(const std::string& data) {
  std::vector<Frame> frames;
  for (size_t p = format::kHeaderSize; p + format::kRecordHeaderSize <= data.size();) {
    Frame frame{p, format::DecodeFixed32(data.data() + p), static_cast<uint8_t>(data[p + 4])};
    frames.push_back(frame);
    p = frame.end();
  }
  return frames;
}

uint32_t StoredCrc(const std::string& data, const Frame& frame) {
  return crc32c::Unmask(format::DecodeFixed32(data.data() + frame.offset + 5));
}
uint32_t ComputedCrc(const std::string& data, const Frame& frame, uint32_t length) {
  return crc32c::Extend(crc32c::Value(data.data() + frame.offset + 4, 1),
                        data.data() + frame.offset + format::kRecordHeaderSize, length);
}
// Makes the stored CRC of `frame` match its (edited) payload again.
void FixCrc(std::string* data, const Frame& frame) {
  PutFixed32At(data, frame.offset + 5, crc32c::Mask(ComputedCrc(*data, frame, frame.length)));
}

// The first slot recorded in a (raw) feature block, and its feature count.
std::pair<int64_t, int64_t> BlockSlots(const std::string& data, const Frame& frame) {
  const char* payload = data.data() + frame.offset + format::kRecordHeaderSize;
  const auto first = static_cast<int64_t>(format::DecodeFixed64(payload));
  return {first, first + format::DecodeFixed32(payload + 16)};
}

class RecordingReporter : public ChunkCorruptionReporter {
 public:
  void Corruption(int64_t bytes, const Status& status) override {
    dropped_bytes += bytes;
    messages.push_back(status.ToString());
  }
  int64_t dropped_bytes = 0;
  std::vector<std::string> messages;
};

class ChunkFormatTest : public ::testing::Test {
 protected:
  void SetUp() override {
    // Parameterized names contain '/': keep the directory one level deep.
    std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    for (char& c : name) {
      if (c == '/') c = '_';
    }
    dir_ = (std::filesystem::temp_directory_path() /
            ("graphslam_chunk_" + name + "_" + std::to_string(::getpid())))
               .string();
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    path_ = dir_ + "/00042.gsc";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // Writes `chunk` with small records (several blocks) and returns the bytes.
  std::string WriteSmallRecords(const core::ObservationChunk& chunk,
                                ChunkCompression compression = ChunkCompression::kNone,
                                uint32_t version = format::kFormatVersion) {
    ChunkWriteOptions options;
    options.compression = compression;
    options.format_version = version;
    options.target_record_bytes = 400;
    const Status status = WriteObservationChunk(Env::Default(), path_, chunk, options);
    EXPECT_TRUE(status.ok()) << status.ToString();
    return Slurp(path_);
  }

  Status Read(core::ObservationChunk* chunk, bool paranoid = true,
              ChunkCorruptionReporter* reporter = nullptr) {
    ChunkReadOptions options;
    options.paranoid = paranoid;
    options.reporter = reporter;
    return ReadObservationChunk(path_, chunk, options);
  }

  std::vector<std::string> Files() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(dir_)) {
      names.push_back(entry.path().filename().string());
    }
    return names;
  }

  std::string dir_;
  std::string path_;
};

// ---------------------------------------------------------------- CRC32C

TEST(Crc32c, MatchesRfc3720Vectors) {
  const std::string zeros(32, '\0');
  const std::string ones(32, '\xff');
  std::string ascending(32, '\0');
  std::string descending(32, '\0');
  for (int i = 0; i < 32; ++i) {
    ascending[i] = static_cast<char>(i);
    descending[i] = static_cast<char>(31 - i);
  }
  for (const bool software : {false, true}) {
    const auto value = [software](const std::string& s) {
      return software ? crc32c::ExtendSoftware(0, s.data(), s.size()) : crc32c::Value(s);
    };
    EXPECT_EQ(value(zeros), 0x8a9136aau);
    EXPECT_EQ(value(ones), 0x62a8ab43u);
    EXPECT_EQ(value(ascending), 0x46dd794eu);
    EXPECT_EQ(value(descending), 0x113fdb5cu);
    EXPECT_EQ(value("123456789"), 0xe3069283u);
  }
}

TEST(Crc32c, ExtendEqualsValueOfConcatenationAndBothPathsAgree) {
  std::mt19937 random(7);
  std::string data(4099, '\0');
  for (char& c : data) c = static_cast<char>(random());
  for (size_t begin : {0, 1, 3, 8, 13}) {
    for (size_t split : {0, 1, 7, 64, 1000, 4000}) {
      const char* p = data.data() + begin;
      const size_t n = data.size() - begin;
      if (split > n) continue;
      EXPECT_EQ(crc32c::Extend(crc32c::Value(p, split), p + split, n - split),
                crc32c::Value(p, n));
      EXPECT_EQ(crc32c::ExtendSoftware(0, p, n), crc32c::Value(p, n));
    }
  }
}

TEST(Crc32c, MaskIsInvertibleAndChangesTheValue) {
  for (const uint32_t crc : {0u, 1u, 0x8a9136aau, 0xffffffffu}) {
    EXPECT_NE(crc32c::Mask(crc), crc);
    EXPECT_NE(crc32c::Mask(crc32c::Mask(crc)), crc32c::Mask(crc));
    EXPECT_EQ(crc32c::Unmask(crc32c::Mask(crc)), crc);
  }
}

// ---------------------------------------------------------------- round trips

class ChunkRoundTripTest : public ChunkFormatTest,
                           public ::testing::WithParamInterface<ChunkCompression> {};

TEST_P(ChunkRoundTripTest, SmallRecordsAreBitExact) {
  const core::ObservationChunk chunk = MakeChunk(42, 200, 6, 1);
  const std::string data = WriteSmallRecords(chunk, GetParam());
  EXPECT_GT(Frames(data).size(), 10u);  // many blocks, then the footer
  core::ObservationChunk read;
  const Status status = Read(&read);
  ASSERT_TRUE(status.ok()) << status.ToString();
  ExpectBitExact(chunk, read);
  EXPECT_EQ(Files(), std::vector<std::string>{"00042.gsc"});  // no temporary left
}

TEST_P(ChunkRoundTripTest, EmptyChunkIsHeaderAndFooterOnly) {
  for (const bool empty_begin : {true, false}) {
    core::ObservationChunk chunk;
    chunk.index = 7;
    if (!empty_begin) chunk.feature_begin = {0};
    ChunkWriteOptions options;
    options.compression = GetParam();
    ASSERT_TRUE(WriteObservationChunk(Env::Default(), path_, chunk, options).ok());
    EXPECT_EQ(Slurp(path_).size(),
              format::kHeaderSize + format::kRecordHeaderSize + format::kFooterSize);
    core::ObservationChunk read = MakeChunk(1, 3, 2, 3);  // storage to be replaced
    const Status status = Read(&read);
    ASSERT_TRUE(status.ok()) << status.ToString();
    chunk.feature_begin = {0};  // the canonical form a reader returns
    ExpectBitExact(chunk, read);
  }
}

TEST_P(ChunkRoundTripTest, LargeChunkWithOneHundredThousandObservations) {
  core::ObservationChunk chunk = MakeChunk(3, 30000, 6, 2);
  ASSERT_GE(chunk.observations.size(), 70000u);
  // Top up to exactly 100 000 observations with one heavily observed feature.
  const int32_t last = chunk.features.back() + 1;
  core::Observation o = chunk.observations.front();
  o.feature = last;
  chunk.features.push_back(last);
  while (chunk.observations.size() < 100000) {
    o.pose = static_cast<int32_t>(chunk.observations.size());
    chunk.observations.push_back(o);
  }
  chunk.feature_begin.push_back(100000);
  ChunkWriteOptions options;
  options.compression = GetParam();
  ASSERT_TRUE(WriteObservationChunk(Env::Default(), path_, chunk, options).ok());
  const std::string data = Slurp(path_);
  if (GetParam() == ChunkCompression::kNone) {
    EXPECT_GT(data.size(), format::kHeaderSize + 100000 * format::kColumnsSize);
  }
  if (GetParam() == ChunkCompression::kZstd) {
    EXPECT_EQ(format::DecodeFixed32(data.data() + 12), format::kFlagZstd);
    // The repeated feature compresses: below one version 1 record each.
    EXPECT_LT(data.size(), format::kHeaderSize + 100000 * format::kObservationSize);
  }
  core::ObservationChunk read;
  const Status status = Read(&read);
  ASSERT_TRUE(status.ok()) << status.ToString();
  ExpectBitExact(chunk, read);
}

TEST_F(ChunkFormatTest, EveryZstdLevelReadsBackTheSameChunk) {
  // The level is the writer's choice (ChunkWriteOptions::zstd_level, 2 by
  // default): the reader needs none, and every level gives the same chunk.
  const core::ObservationChunk chunk = MakeChunk(5, 3000, 6, 4);
  for (const int level : {ChunkWriteOptions().zstd_level, -1, 1, 3}) {
    SCOPED_TRACE("level " + std::to_string(level));
    ChunkWriteOptions options;
    options.compression = ChunkCompression::kZstd;
    options.zstd_level = level;
    ASSERT_TRUE(WriteObservationChunk(Env::Default(), path_, chunk, options).ok());
    const std::string data = Slurp(path_);
    bool compressed = false;
    for (const Frame& frame : Frames(data))
      compressed = compressed || (frame.type & format::kCompressedBit) != 0;
    EXPECT_TRUE(compressed) << "no block stored compressed";
    core::ObservationChunk read;
    const Status status = Read(&read);
    ASSERT_TRUE(status.ok()) << status.ToString();
    ExpectBitExact(chunk, read);
  }
}

INSTANTIATE_TEST_SUITE_P(Compression, ChunkRoundTripTest,
                         ::testing::Values(ChunkCompression::kNone, ChunkCompression::kZstd),
                         [](const auto& info) {
                           return info.param == ChunkCompression::kNone ? "None" : "Zstd";
                         });

// ---------------------------------------------------------------- header damage

TEST_F(ChunkFormatTest, FlippedHeaderByteIsACrcMismatchAtByteZero) {
  std::string data = WriteSmallRecords(MakeChunk(42, 50, 4, 4));
  data[20] ^= 0x01;  // inside the chunk index
  Spit(path_, data);
  const uint32_t expected = crc32c::Unmask(format::DecodeFixed32(data.data() + 44));
  const uint32_t actual = crc32c::Value(data.data(), 44);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), path_ + ": header at byte 0: crc mismatch (expected " +
                                  Hex32(expected) + ", got " + Hex32(actual) + ")");
  // Header damage is fatal in non-paranoid mode too, and nothing is reported.
  RecordingReporter reporter;
  EXPECT_EQ(Read(&read, false, &reporter).message(), status.message());
  EXPECT_TRUE(reporter.messages.empty());
}

TEST_F(ChunkFormatTest, FlippedMagicByteSaysNotAnObservationChunk) {
  std::string data = WriteSmallRecords(MakeChunk(42, 5, 4, 4));
  data[1] ^= 0x20;  // 'G' -> 'g'
  Spit(path_, data);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), path_ +
                                  ": header at byte 0: bad magic number (expected "
                                  "0x0a1a0a0d43534789, got 0x0a1a0a0d43536789): not an "
                                  "observation chunk");
}

TEST_F(ChunkFormatTest, NewerVersionIsNotSupported) {
  std::string data = WriteSmallRecords(MakeChunk(42, 5, 4, 4));
  PutFixed32At(&data, 8, 3);
  PutFixed32At(&data, 44, crc32c::Mask(crc32c::Value(data.data(), 44)));
  Spit(path_, data);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsNotSupported());
  EXPECT_EQ(status.message(),
            path_ + ": header at byte 8: format version 3 is newer than this reader (2)");
}

TEST_F(ChunkFormatTest, UnknownFlagIsNotSupported) {
  std::string data = WriteSmallRecords(MakeChunk(42, 5, 4, 4));
  PutFixed32At(&data, 12, 0x4);
  PutFixed32At(&data, 44, crc32c::Mask(crc32c::Value(data.data(), 44)));
  Spit(path_, data);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsNotSupported());
  EXPECT_EQ(status.message(), path_ +
                                  ": header at byte 12: unknown flags 0x00000004 (this reader "
                                  "knows 0x00000001)");
}

// ---------------------------------------------------------------- record damage

struct DamageCase {
  ChunkCompression compression;
  uint32_t version;
};

class ChunkRecordDamageTest : public ChunkFormatTest,
                              public ::testing::WithParamInterface<DamageCase> {};

TEST_P(ChunkRecordDamageTest, FlippedPayloadByteNamesRecordOffsetAndBothCrcs) {
  const core::ObservationChunk chunk = MakeChunk(42, 120, 5, 5);
  std::string data = WriteSmallRecords(chunk, GetParam().compression, GetParam().version);
  ASSERT_EQ(format::DecodeFixed32(data.data() + 8), GetParam().version);
  const std::vector<Frame> frames = Frames(data);
  ASSERT_GE(frames.size(), 5u);
  const Frame& damaged = frames[3];
  data[damaged.offset + format::kRecordHeaderSize + damaged.length / 2] ^= 0x40;
  Spit(path_, data);
  const std::string expected_message =
      path_ + ": record 3 at byte " + std::to_string(damaged.offset) + ": crc mismatch (expected " +
      Hex32(StoredCrc(data, damaged)) + ", got " + Hex32(ComputedCrc(data, damaged, damaged.length)) +
      ")";

  core::ObservationChunk read = chunk;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), expected_message);
  ExpectBitExact(chunk, read);  // untouched on error

  // Non-paranoid: exactly that record's bytes are dropped, the rest is kept.
  RecordingReporter reporter;
  const Status relaxed = Read(&read, false, &reporter);
  ASSERT_TRUE(relaxed.ok()) << relaxed.ToString();
  EXPECT_EQ(reporter.dropped_bytes, static_cast<int64_t>(format::kRecordHeaderSize + damaged.length));
  ASSERT_EQ(reporter.messages.size(), 1u);
  EXPECT_EQ(reporter.messages[0], "Corruption: " + expected_message);
  // What survives is the chunk minus one contiguous run of whole features.
  int64_t begin = 0;
  while (begin < read.num_features() && read.features[begin] == chunk.features[begin]) ++begin;
  const int64_t end = begin + chunk.num_features() - read.num_features();
  EXPECT_GT(end, begin);
  if (GetParam().compression == ChunkCompression::kNone) {  // raw blocks: their headers say which run
    EXPECT_EQ(begin, BlockSlots(data, frames[2]).second);
    EXPECT_EQ(end, BlockSlots(data, frames[4]).first);
  }
  ExpectBitExact(WithoutSlots(chunk, begin, end), read);
}

INSTANTIATE_TEST_SUITE_P(
    CompressionAndVersion, ChunkRecordDamageTest,
    ::testing::Values(DamageCase{ChunkCompression::kNone, 1}, DamageCase{ChunkCompression::kZstd, 1},
                      DamageCase{ChunkCompression::kNone, 2}, DamageCase{ChunkCompression::kZstd, 2}),
    [](const auto& info) {
      return std::string(info.param.compression == ChunkCompression::kNone ? "None" : "Zstd") +
             "V" + std::to_string(info.param.version);
    });

TEST_F(ChunkFormatTest, FlippedCrcByteIsACrcMismatch) {
  const core::ObservationChunk chunk = MakeChunk(42, 60, 5, 6);
  std::string data = WriteSmallRecords(chunk);
  const std::vector<Frame> frames = Frames(data);
  const Frame& damaged = frames[1];
  const uint32_t computed = ComputedCrc(data, damaged, damaged.length);
  data[damaged.offset + 6] ^= 0x01;
  Spit(path_, data);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), path_ + ": record 1 at byte " + std::to_string(damaged.offset) +
                                  ": crc mismatch (expected " + Hex32(StoredCrc(data, damaged)) +
                                  ", got " + Hex32(computed) + ")");
  EXPECT_NE(StoredCrc(data, damaged), computed);
}

TEST_F(ChunkFormatTest, FlippedFooterByteIsACrcMismatchOfTheLastRecord) {
  std::string data = WriteSmallRecords(MakeChunk(42, 60, 5, 6));
  const std::vector<Frame> frames = Frames(data);
  const Frame& footer = frames.back();
  ASSERT_EQ(footer.type, format::kFooter);
  data[footer.offset + format::kRecordHeaderSize + 3] ^= 0x10;
  Spit(path_, data);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), path_ + ": record " + std::to_string(frames.size() - 1) +
                                  " at byte " + std::to_string(footer.offset) +
                                  ": crc mismatch (expected " + Hex32(StoredCrc(data, footer)) +
                                  ", got " + Hex32(ComputedCrc(data, footer, footer.length)) + ")");
}

TEST_F(ChunkFormatTest, LengthPastTheEndOfTheFileIsReportedAndDropsTheRest) {
  const core::ObservationChunk chunk = MakeChunk(42, 60, 5, 7);
  std::string data = WriteSmallRecords(chunk);
  const std::vector<Frame> frames = Frames(data);
  const Frame& damaged = frames[2];
  PutFixed32At(&data, damaged.offset, 0xFFFFFFF0u);
  Spit(path_, data);
  const size_t left = data.size() - damaged.offset - format::kRecordHeaderSize;
  const std::string expected_message =
      path_ + ": record 2 at byte " + std::to_string(damaged.offset) +
      ": length 4294967280 exceeds the " + std::to_string(left) +
      " bytes left in the file after the record header (bad length or truncated file)";
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), expected_message);

  RecordingReporter reporter;
  ASSERT_TRUE(Read(&read, false, &reporter).ok());
  EXPECT_EQ(reporter.dropped_bytes, static_cast<int64_t>(data.size() - damaged.offset));
  EXPECT_EQ(reporter.messages, std::vector<std::string>{"Corruption: " + expected_message});
  ExpectBitExact(WithoutSlots(chunk, BlockSlots(data, frames[1]).second, chunk.num_features()),
                 read);
}

TEST_F(ChunkFormatTest, ShorterLengthIsACrcMismatchOfTheShortenedRecord) {
  std::string data = WriteSmallRecords(MakeChunk(42, 60, 5, 8));
  const std::vector<Frame> frames = Frames(data);
  const Frame& damaged = frames[1];
  const uint32_t shorter = damaged.length - static_cast<uint32_t>(format::kObservationSize);
  PutFixed32At(&data, damaged.offset, shorter);
  Spit(path_, data);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), path_ + ": record 1 at byte " + std::to_string(damaged.offset) +
                                  ": crc mismatch (expected " + Hex32(StoredCrc(data, damaged)) +
                                  ", got " + Hex32(ComputedCrc(data, damaged, shorter)) + ")");
}

TEST_F(ChunkFormatTest, NonParanoidReportsEveryDamagedRecordWithItsExactSize) {
  const core::ObservationChunk chunk = MakeChunk(42, 120, 5, 17);
  std::string data = WriteSmallRecords(chunk);
  const std::vector<Frame> frames = Frames(data);
  ASSERT_GE(frames.size(), 8u);
  for (const size_t r : {1u, 5u}) data[frames[r].offset + format::kRecordHeaderSize + 30] ^= 1;
  data[frames.back().offset + format::kRecordHeaderSize] ^= 1;  // the footer too
  Spit(path_, data);
  RecordingReporter reporter;
  core::ObservationChunk read;
  ASSERT_TRUE(Read(&read, false, &reporter).ok());
  ASSERT_EQ(reporter.messages.size(), 4u);  // two blocks, the footer, then "no valid footer"
  EXPECT_EQ(reporter.dropped_bytes,
            static_cast<int64_t>(3 * format::kRecordHeaderSize + frames[1].length +
                                 frames[5].length + format::kFooterSize));
  EXPECT_EQ(reporter.messages[3],
            "Corruption: " + path_ + ": at byte " + std::to_string(data.size()) +
                ": the file ends without a valid footer after " + std::to_string(frames.size()) +
                " records (the header promises 120 features and " +
                std::to_string(chunk.observations.size()) + " observations; read " +
                std::to_string(read.features.size()) + " and " +
                std::to_string(read.observations.size()) + ")");
  core::ObservationChunk expected =
      WithoutSlots(chunk, BlockSlots(data, frames[5]).first, BlockSlots(data, frames[5]).second);
  expected = WithoutSlots(expected, BlockSlots(data, frames[1]).first,
                          BlockSlots(data, frames[1]).second);
  ExpectBitExact(expected, read);
}

TEST_F(ChunkFormatTest, CompressedRecordWithoutTheHeaderFlagIsCorruption) {
  core::ObservationChunk chunk = MakeChunk(42, 40, 5, 18);
  for (core::Observation& o : chunk.observations) o.z = {1.0, 2.0};  // compressible
  std::string data = WriteSmallRecords(chunk, ChunkCompression::kZstd);
  const std::vector<Frame> frames = Frames(data);
  ASSERT_EQ(frames[0].type, format::kFeatureBlock | format::kCompressedBit);
  PutFixed32At(&data, 12, 0);
  PutFixed32At(&data, 44, crc32c::Mask(crc32c::Value(data.data(), 44)));
  Spit(path_, data);
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(), path_ +
                                  ": record 0 at byte 48: compressed record in a file whose "
                                  "header (flags 0x00000000) does not allow compression");
}

// ---------------------------------------------------------------- truncation

TEST_F(ChunkFormatTest, TruncationAnywhereIsACorruptionNamingTheOffset) {
  const core::ObservationChunk chunk = MakeChunk(42, 60, 5, 9);
  const std::string data = WriteSmallRecords(chunk);
  const std::vector<Frame> frames = Frames(data);
  const Frame& middle = frames[2];
  const Frame& footer = frames.back();
  struct Cut {
    size_t size;
    std::string message;
  };
  const auto no_footer = [&](size_t size, size_t records, int64_t features, int64_t observations) {
    return path_ + ": truncated at byte " + std::to_string(size) + ": no footer after " +
           std::to_string(records) + " records (the header promises 60 features and " +
           std::to_string(chunk.observations.size()) + " observations; read " +
           std::to_string(features) + " and " + std::to_string(observations) + ")";
  };
  const auto [slots_before_middle_end, slots_middle_end] = BlockSlots(data, middle);
  (void)slots_before_middle_end;
  const std::vector<Cut> cuts = {
      {0, path_ + ": truncated at byte 0: the file is shorter than the 48-byte header"},
      {30, path_ + ": truncated at byte 30: the file is shorter than the 48-byte header"},
      {format::kHeaderSize, no_footer(format::kHeaderSize, 0, 0, 0)},
      {middle.offset + 4, path_ + ": record 2 at byte " + std::to_string(middle.offset) +
                              ": truncated record header (9 bytes expected, 4 left in the file)"},
      {middle.offset + 100,
       path_ + ": record 2 at byte " + std::to_string(middle.offset) + ": length " +
           std::to_string(middle.length) +
           " exceeds the 91 bytes left in the file after the record header (bad length or "
           "truncated file)"},
      {middle.end(), no_footer(middle.end(), 3, slots_middle_end,
                               chunk.feature_begin[slots_middle_end])},
      {footer.offset, no_footer(footer.offset, frames.size() - 1, 60,
                                static_cast<int64_t>(chunk.observations.size()))},
      {data.size() - 1,
       path_ + ": record " + std::to_string(frames.size() - 1) + " at byte " +
           std::to_string(footer.offset) +
           ": length 24 exceeds the 23 bytes left in the file after the record header (bad "
           "length or truncated file)"},
  };
  for (const Cut& cut : cuts) {
    SCOPED_TRACE("cut at " + std::to_string(cut.size));
    Spit(path_, data.substr(0, cut.size));
    core::ObservationChunk read;
    const Status status = Read(&read);
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_EQ(status.message(), cut.message);
  }
}

TEST_F(ChunkFormatTest, TruncatedFileNonParanoidKeepsWholeBlocksAndReportsTheRest) {
  const core::ObservationChunk chunk = MakeChunk(42, 60, 5, 10);
  const std::string data = WriteSmallRecords(chunk);
  const std::vector<Frame> frames = Frames(data);
  const size_t cut = frames[3].offset + 50;
  Spit(path_, data.substr(0, cut));
  RecordingReporter reporter;
  core::ObservationChunk read;
  ASSERT_TRUE(Read(&read, false, &reporter).ok());
  EXPECT_EQ(reporter.dropped_bytes, static_cast<int64_t>(cut - frames[3].offset));
  ASSERT_EQ(reporter.messages.size(), 1u);
  ExpectBitExact(WithoutSlots(chunk, BlockSlots(data, frames[2]).second, chunk.num_features()),
                 read);
}

TEST_F(ChunkFormatTest, BytesAfterTheFooterAreCorruption) {
  const core::ObservationChunk chunk = MakeChunk(42, 20, 5, 11);
  const std::string data = WriteSmallRecords(chunk) + "garbage";
  Spit(path_, data);
  const std::string expected_message = path_ + ": 7 bytes after the footer that ends at byte " +
                                       std::to_string(data.size() - 7) +
                                       " (expected the end of the file)";
  core::ObservationChunk read;
  EXPECT_EQ(Read(&read).message(), expected_message);
  RecordingReporter reporter;
  ASSERT_TRUE(Read(&read, false, &reporter).ok());
  EXPECT_EQ(reporter.dropped_bytes, 7);
  ExpectBitExact(chunk, read);
}

// ---------------------------------------------------------------- valid CRC, bad content

TEST_F(ChunkFormatTest, InvalidVersion1ObservationUnderAValidCrcNamesObservationAndSlot) {
  const core::ObservationChunk chunk = MakeChunk(42, 10, 3, 12);
  const std::string original = WriteSmallRecords(chunk, ChunkCompression::kNone, 1);
  const Frame first = Frames(original).front();
  const size_t observations_at = first.offset + format::kRecordHeaderSize +
                                 format::kBlockHeaderSize +
                                 format::kFeatureEntrySize * BlockSlots(original, first).second;
  const std::string where = path_ + ": record 0 at byte 48: observation 1 (feature slot 0 (feature " +
                            std::to_string(chunk.features[0]) + ")): ";
  ASSERT_GE(chunk.feature_begin[1], 2);  // observation 1 belongs to slot 0
  struct Edit {
    size_t field;  // offset within the observation
    uint64_t value;
    int bytes;
    std::string problem;
  };
  const std::vector<Edit> edits = {
      {8, 7, 1,
       "kind 7 is not an ObservationKind (expected " + core::ObservationKindRange() + ")"},
      {4, 999999, 4,
       "feature is 999999, expected " + std::to_string(chunk.features[0]) +
           " (the feature of its slot)"},
      {0, 0xFFFFFFFFu, 4, "pose -1 is negative"},
      {17, std::bit_cast<uint64_t>(std::numeric_limits<double>::quiet_NaN()), 8,
       "z[1] is not finite"},
      {33, std::bit_cast<uint64_t>(std::numeric_limits<double>::infinity()), 8,
       "information(1,0) is not finite"},
  };
  for (const Edit& edit : edits) {
    SCOPED_TRACE(edit.problem);
    std::string data = original;
    const size_t at = observations_at + format::kObservationSize + edit.field;
    for (int i = 0; i < edit.bytes; ++i) data[at + i] = static_cast<char>((edit.value >> (8 * i)) & 0xFF);
    FixCrc(&data, first);
    Spit(path_, data);
    core::ObservationChunk read;
    const Status status = Read(&read);
    EXPECT_TRUE(status.IsCorruption());
    EXPECT_EQ(status.message(), where + edit.problem);
  }
}

// Version 2 keeps the feature implied by its slot and the information in a
// table: damage there is named like any other bad field.
TEST_F(ChunkFormatTest, InvalidVersion2ObservationUnderAValidCrcNamesObservationAndSlot) {
  core::ObservationChunk chunk = MakeChunk(42, 10, 3, 12);
  for (size_t i = 0; i < chunk.observations.size(); ++i) {  // three distinct: a u8 index
    chunk.observations[i].information = Eigen::Vector2d(1.0 + static_cast<double>(i % 3), 2.0).asDiagonal();
  }
  ASSERT_TRUE(WriteObservationChunk(Env::Default(), path_, chunk).ok());
  const std::string original = Slurp(path_);
  const Frame first = Frames(original).front();
  const size_t n = chunk.observations.size();
  ASSERT_EQ(BlockSlots(original, first).second, 10);  // one block holds the chunk
  ASSERT_EQ(first.length, format::kBlockHeaderSize + format::kFeatureEntrySize * 10 +
                              format::kInformationCountSize + 3 * format::kInformationSize +
                              (format::kColumnsSize + 1) * n);
  const size_t table_end =
      first.offset + format::kRecordHeaderSize + format::kBlockHeaderSize + format::kFeatureEntrySize * 10;
  const size_t table_at = table_end + format::kInformationCountSize;
  const size_t columns_at = table_at + 3 * format::kInformationSize;
  const std::string record = path_ + ": record 0 at byte 48: ";
  const std::string where = record + "observation 1 (feature slot 0 (feature " +
                            std::to_string(chunk.features[0]) + ")): ";
  ASSERT_GE(chunk.feature_begin[1], 2);  // observation 1 belongs to slot 0
  const uint32_t pose0 = static_cast<uint32_t>(chunk.observations[0].pose);
  struct Edit {
    size_t at;
    uint64_t value;
    int bytes;
    std::string message;
  };
  const std::vector<Edit> edits = {
      {columns_at + 4 * n + 1, 7, 1,
       where + "kind 7 is not an ObservationKind (expected " + core::ObservationKindRange() + ")"},
      {columns_at + 4, 0xFFFFFFFFu - pose0, 4, where + "pose -1 is negative"},  // a delta
      {columns_at + 13 * n + 8, std::bit_cast<uint64_t>(std::numeric_limits<double>::quiet_NaN()), 8,
       where + "z[1] is not finite"},
      {table_at + format::kInformationSize + 8,
       std::bit_cast<uint64_t>(std::numeric_limits<double>::infinity()), 8,
       where + "information(1,0) is not finite"},  // entry 1, used by observation 1
      {columns_at + 21 * n + 1, 3, 1,
       where + "information index 3 is not below the 3 entries of the block's table"},
      {table_end, n + 1, 4,
       record + "information table of " + std::to_string(n + 1) + " entries for " +
           std::to_string(n) + " observations (expected 1 entry, one per observation, or at "
           "most 65536 and no more than the observations)"},
  };
  for (const Edit& edit : edits) {
    SCOPED_TRACE(edit.message);
    std::string data = original;
    for (int i = 0; i < edit.bytes; ++i) {
      data[edit.at + i] = static_cast<char>((edit.value >> (8 * i)) & 0xFF);
    }
    FixCrc(&data, first);
    Spit(path_, data);
    core::ObservationChunk read;
    const Status status = Read(&read);
    EXPECT_TRUE(status.IsCorruption());
    EXPECT_EQ(status.message(), edit.message);
    // Non-paranoid: the block is skipped, as any damaged block.
    RecordingReporter reporter;
    ASSERT_TRUE(Read(&read, false, &reporter).ok());
    EXPECT_EQ(reporter.dropped_bytes, static_cast<int64_t>(format::kRecordHeaderSize + first.length));
    EXPECT_EQ(read.num_features(), 0);
  }
}

// ---------------------------------------------------------------- version 2 layout

// `observations` observations over features of four each, kinds cycling
// through every model, informations drawn from `distinct` matrices
// (observation i uses matrix i % distinct; matrices 0 and 1 differ only in
// the sign of a zero), poses and lines spanning the whole i32 range so that
// the wrapping deltas are exercised.
core::ObservationChunk ChunkWithInformations(int observations, int distinct, uint32_t seed) {
  std::mt19937 random(seed);
  std::normal_distribution<double> normal(0.0, 10.0);
  const core::ObservationKind kinds[] = {core::ObservationKind::kRangeBearing,
                                         core::ObservationKind::kPointXY,
                                         core::ObservationKind::kBearing};
  core::ObservationChunk chunk;
  chunk.index = 4;
  chunk.feature_begin.push_back(0);
  for (int i = 0; i < observations; ++i) {
    if (i % 4 == 0) {
      if (i > 0) chunk.feature_begin.push_back(i);
      chunk.features.push_back(3 * (i / 4) + 1);
    }
    core::Observation o;
    o.feature = chunk.features.back();
    o.kind = kinds[i % 3];
    o.pose = i % 5 == 0 ? std::numeric_limits<int32_t>::max() - i
                        : static_cast<int32_t>(random() % 100000);
    o.line = i % 7 == 0 ? std::numeric_limits<int32_t>::min() + i
                        : static_cast<int32_t>(random() % 2000000) - 1000000;
    o.z = {normal(random), normal(random)};
    const int m = i % distinct;
    o.information << 1.0 + m, (m == 0 ? -0.0 : 0.0), 0.0, 2.0 + 0.5 * m;
    chunk.observations.push_back(o);
  }
  chunk.feature_begin.push_back(observations);
  return chunk;
}

TEST_F(ChunkFormatTest, Version2RoundTripsMixedKindsAndInformationsInOneBlock) {
  struct Case {
    int observations;
    int distinct;
    size_t entries;  // expected in the table
    size_t width;    // expected bytes of index per observation
  };
  const std::vector<Case> cases = {
      {1000, 1, 1, 0},        {1000, 2, 2, 1},        {1000, 256, 256, 1},
      {1000, 257, 257, 2},    {3000, 300, 300, 2},    {100, 100, 100, 0},  // all differ
      {100, 99, 100, 0},      // an index would not save space: one entry each
      {70000, 65537, 70000, 0},  // too many to index
  };
  for (const Case& c : cases) {
    const core::ObservationChunk chunk = ChunkWithInformations(c.observations, c.distinct, 21);
    for (const ChunkCompression compression : {ChunkCompression::kNone, ChunkCompression::kZstd}) {
      SCOPED_TRACE(std::to_string(c.observations) + " observations, " +
                   std::to_string(c.distinct) + " informations, compression " +
                   std::to_string(static_cast<int>(compression)));
      ChunkWriteOptions options;
      options.compression = compression;
      options.target_record_bytes = static_cast<int64_t>(format::kMaxRecordLength);
      ASSERT_TRUE(WriteObservationChunk(Env::Default(), path_, chunk, options).ok());
      const std::string data = Slurp(path_);
      EXPECT_EQ(format::DecodeFixed32(data.data() + 8), 2u);
      const std::vector<Frame> frames = Frames(data);
      ASSERT_EQ(frames.size(), 2u);  // one block, the footer
      if (compression == ChunkCompression::kNone) {
        const char* payload = data.data() + frames[0].offset + format::kRecordHeaderSize;
        const size_t features = chunk.features.size();
        const size_t table_end = format::kBlockHeaderSize + format::kFeatureEntrySize * features;
        EXPECT_EQ(format::DecodeFixed32(payload + table_end), c.entries);
        EXPECT_EQ(frames[0].length, table_end + format::kInformationCountSize +
                                        format::kInformationSize * c.entries +
                                        (format::kColumnsSize + c.width) * c.observations);
      }
      core::ObservationChunk read;
      const Status status = Read(&read);
      ASSERT_TRUE(status.ok()) << status.ToString();
      ExpectBitExact(chunk, read);
    }
  }
}

TEST_F(ChunkFormatTest, Version1FilesWrittenOnRequestReadBackTheSame) {
  const core::ObservationChunk chunk = MakeChunk(42, 200, 6, 31);
  for (const ChunkCompression compression : {ChunkCompression::kNone, ChunkCompression::kZstd}) {
    const std::string data = WriteSmallRecords(chunk, compression, 1);
    EXPECT_EQ(format::DecodeFixed32(data.data() + 8), 1u);
    core::ObservationChunk read;
    const Status status = Read(&read);
    ASSERT_TRUE(status.ok()) << status.ToString();
    ExpectBitExact(chunk, read);
  }
}

// A version 1 file put together byte by byte from the specification, not by
// the writer: the reader keeps reading what earlier builds wrote.
TEST_F(ChunkFormatTest, HandEncodedVersion1FileReads) {
  std::string header;
  format::PutFixed64(&header, format::kMagic);
  format::PutFixed32(&header, 1);   // version
  format::PutFixed32(&header, 0);   // flags
  format::PutFixed64(&header, 9);   // chunk index
  format::PutFixed64(&header, 1);   // features
  format::PutFixed64(&header, 2);   // observations
  format::PutFixed32(&header, 0);   // reserved
  format::PutFixed32(&header, crc32c::Mask(crc32c::Value(header)));
  std::string block;
  format::PutFixed64(&block, 0);  // first slot
  format::PutFixed64(&block, 0);  // first observation
  format::PutFixed32(&block, 1);  // feature count
  format::PutFixed32(&block, 5);  // feature 5 ...
  format::PutFixed32(&block, 2);  // ... with 2 observations
  const double z[2][2] = {{3.5, -0.25}, {-0.0, 7.0}};
  const double information[2][4] = {{100, 0, 0, 2500}, {1, 0.5, 0.25, 2}};
  for (int i = 0; i < 2; ++i) {
    format::PutFixed32(&block, static_cast<uint32_t>(11 + i));  // pose
    format::PutFixed32(&block, 5);                              // feature
    block.push_back(static_cast<char>(i));                      // kind 0, 1
    for (const double v : z[i]) format::PutDouble(&block, v);
    for (const double v : information[i]) format::PutDouble(&block, v);
    format::PutFixed32(&block, static_cast<uint32_t>(-3 + 100 * i));  // line
  }
  ASSERT_EQ(block.size(), 20 + 8 + 2 * 61u);
  const auto frame = [](uint8_t type, const std::string& payload) {
    const char type_byte = static_cast<char>(type);
    const uint32_t crc = crc32c::Mask(
        crc32c::Extend(crc32c::Value(&type_byte, 1), payload.data(), payload.size()));
    std::string out;
    format::PutFixed32(&out, static_cast<uint32_t>(payload.size()));
    out.push_back(type_byte);
    format::PutFixed32(&out, crc);
    return std::make_pair(out + payload, crc);
  };
  const auto [block_record, block_crc] = frame(format::kFeatureBlock, block);
  std::string chain_bytes = header.substr(44, 4);
  format::PutFixed32(&chain_bytes, block_crc);
  std::string footer;
  format::PutFixed64(&footer, 1);
  format::PutFixed64(&footer, 2);
  format::PutFixed32(&footer, 1);
  format::PutFixed32(&footer, crc32c::Mask(crc32c::Value(chain_bytes)));
  Spit(path_, header + block_record + frame(format::kFooter, footer).first);

  core::ObservationChunk read;
  const Status status = Read(&read);
  ASSERT_TRUE(status.ok()) << status.ToString();
  core::ObservationChunk expected;
  expected.index = 9;
  expected.features = {5};
  expected.feature_begin = {0, 2};
  for (int i = 0; i < 2; ++i) {
    core::Observation o;
    o.pose = 11 + i;
    o.feature = 5;
    o.kind = static_cast<core::ObservationKind>(i);
    o.z = {z[i][0], z[i][1]};
    for (int j = 0; j < 4; ++j) o.information.data()[j] = information[i][j];
    o.line = -3 + 100 * i;
    expected.observations.push_back(o);
  }
  ExpectBitExact(expected, read);
}

// What the simulator and the native log make: one sensor (one kind, one
// information), features seen from runs of consecutive poses.
TEST_F(ChunkFormatTest, Version2ShrinksATypicalBlock) {
  std::mt19937 random(5);
  std::normal_distribution<double> normal(0.0, 1.0);
  core::ObservationChunk chunk;
  chunk.index = 1;
  chunk.feature_begin.push_back(0);
  for (int k = 0; k < 500; ++k) {
    chunk.features.push_back(1000000 + k);
    for (int i = 0; i < 8; ++i) {
      core::Observation o;
      o.pose = k / 4 + i;
      o.feature = chunk.features.back();
      o.z = {7.5 + normal(random), 1.3 + 0.1 * normal(random)};
      o.information = Eigen::Vector2d(100.0, 2500.0).asDiagonal();
      o.line = 3 + 40 * (k / 4 + i) + k % 4;
      chunk.observations.push_back(o);
    }
    chunk.feature_begin.push_back(static_cast<int64_t>(chunk.observations.size()));
  }
  const size_t n = chunk.observations.size();
  std::map<std::pair<uint32_t, ChunkCompression>, size_t> sizes;
  for (const uint32_t version : {1u, 2u}) {
    for (const ChunkCompression compression : {ChunkCompression::kNone, ChunkCompression::kZstd}) {
      ChunkWriteOptions options;
      options.compression = compression;
      options.format_version = version;
      ASSERT_TRUE(WriteObservationChunk(Env::Default(), path_, chunk, options).ok());
      sizes[{version, compression}] = Slurp(path_).size();
      core::ObservationChunk read;
      ASSERT_TRUE(Read(&read).ok());
      ExpectBitExact(chunk, read);
    }
  }
  const size_t frame_bytes = format::kHeaderSize + 2 * format::kRecordHeaderSize + format::kFooterSize;
  const size_t table_bytes = format::kBlockHeaderSize + format::kFeatureEntrySize * 500;
  const size_t v1_raw = sizes[{1u, ChunkCompression::kNone}];
  const size_t v2_raw = sizes[{2u, ChunkCompression::kNone}];
  const size_t v1_zstd = sizes[{1u, ChunkCompression::kZstd}];
  const size_t v2_zstd = sizes[{2u, ChunkCompression::kZstd}];
  EXPECT_EQ(v1_raw,
            frame_bytes + table_bytes + format::kObservationSize * n);
  // One table entry, no index column: 25 bytes an observation instead of 61.
  EXPECT_EQ(v2_raw,
            frame_bytes + table_bytes + format::kInformationCountSize + format::kInformationSize +
                format::kColumnsSize * n);
  // Compressed, the columns are smaller too (z is noise and dominates both).
  EXPECT_LT(v2_zstd, v1_zstd);
}

TEST_F(ChunkFormatTest, UnknownFormatVersionToWriteIsInvalidArgument) {
  ChunkWriteOptions options;
  options.format_version = 3;
  const Status status = WriteObservationChunk(Env::Default(), path_, MakeChunk(42, 3, 2, 1), options);
  EXPECT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(status.message(),
            "writing " + path_ + ": ChunkWriteOptions::format_version is 3, expected 1 to 2");
  EXPECT_TRUE(Files().empty());
}

TEST_F(ChunkFormatTest, SwappedRecordsBreakContinuity) {
  const core::ObservationChunk chunk = MakeChunk(42, 60, 5, 13);
  const std::string data = WriteSmallRecords(chunk);
  const std::vector<Frame> frames = Frames(data);
  const Frame& a = frames[1];
  const Frame& b = frames[2];
  std::string swapped = data.substr(0, a.offset) + data.substr(b.offset, b.end() - b.offset) +
                        data.substr(a.offset, a.end() - a.offset) + data.substr(b.end());
  Spit(path_, swapped);
  const auto [b_first, b_end] = BlockSlots(data, b);
  (void)b_end;
  const auto [a_first, a_end] = BlockSlots(data, a);
  (void)a_end;
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsCorruption());
  EXPECT_EQ(status.message(),
            path_ + ": record 1 at byte " + std::to_string(a.offset) +
                ": block starts at feature slot " + std::to_string(b_first) + " and observation " +
                std::to_string(chunk.feature_begin[b_first]) + ", expected " +
                std::to_string(a_first) + " and " + std::to_string(chunk.feature_begin[a_first]) +
                " (a record is missing, repeated or out of order)");
}

// ---------------------------------------------------------------- writer input

TEST_F(ChunkFormatTest, InvalidChunkIsRejectedBeforeAnyFileIsWritten) {
  const core::ObservationChunk good = MakeChunk(42, 10, 3, 14);
  struct Case {
    std::function<void(core::ObservationChunk*)> damage;
    std::string message;
  };
  const std::string prefix = "writing " + path_ + ": chunk 42: ";
  const std::vector<Case> cases = {
      {[](core::ObservationChunk* c) {
         // Slot 3 repeats the feature of slot 2 (its observations agree).
         c->features[3] = c->features[2];
         for (int64_t o = c->feature_begin[3]; o < c->feature_begin[4]; ++o) {
           c->observations[o].feature = c->features[2];
         }
       },
       prefix + "feature slot 3 (feature " + std::to_string(good.features[2]) +
           "): expected a feature above " + std::to_string(good.features[2]) +
           " (features must be strictly ascending)"},
      {[](core::ObservationChunk* c) { c->feature_begin.pop_back(); },
       prefix + "feature_begin has 10 entries, expected 11 (features + 1)"},
      {[](core::ObservationChunk* c) { c->observations[0].feature += 1; },
       prefix + "observation 0 (feature slot 0): feature is " +
           std::to_string(good.features[0] + 1) + ", expected " + std::to_string(good.features[0]) +
           " (the feature of its slot)"},
      {[](core::ObservationChunk* c) { c->observations[1].z[0] = std::nan(""); },
       prefix + "observation 1 (feature slot " +
           std::to_string(good.feature_begin[1] > 1 ? 0 : 1) + "): z[0] is not finite"},
  };
  for (const Case& c : cases) {
    core::ObservationChunk chunk = good;
    c.damage(&chunk);
    const Status status = WriteObservationChunk(Env::Default(), path_, chunk);
    EXPECT_TRUE(status.IsInvalidArgument());
    EXPECT_EQ(status.message(), c.message);
    EXPECT_TRUE(Files().empty());
  }
  ChunkWriteOptions options;
  options.target_record_bytes = 0;
  const Status status = WriteObservationChunk(Env::Default(), path_, good, options);
  EXPECT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(status.message(), "writing " + path_ +
                                  ": ChunkWriteOptions::target_record_bytes is 0, expected [1, " +
                                  std::to_string(format::kMaxRecordLength) + "]");
  EXPECT_TRUE(Files().empty());
}

TEST_F(ChunkFormatTest, MissingFileIsNotFound) {
  core::ObservationChunk read;
  const Status status = Read(&read);
  EXPECT_TRUE(status.IsNotFound());
  EXPECT_EQ(status.message(), path_ + ": open: No such file or directory");
}

// ---------------------------------------------------------------- I/O faults

struct FaultCase {
  Operation operation;
  int nth;
  const char* name;
};

class ChunkFaultTest : public ChunkFormatTest, public ::testing::WithParamInterface<FaultCase> {};

TEST_P(ChunkFaultTest, IOErrorKeepsThePreviousChunkReadable) {
  const core::ObservationChunk previous = MakeChunk(42, 80, 5, 15);
  const std::string previous_bytes = WriteSmallRecords(previous);
  const core::ObservationChunk next = MakeChunk(42, 90, 5, 16);

  FaultInjectionEnv env(Env::Default());
  env.FailAt(GetParam().operation, GetParam().nth);
  ChunkWriteOptions options;
  options.target_record_bytes = 400;
  const Status status = WriteObservationChunk(&env, path_, next, options);
  EXPECT_TRUE(status.IsIOError()) << status.ToString();
  EXPECT_EQ(status.message().rfind("writing " + path_ + ": ", 0), 0u) << status.message();
  EXPECT_NE(status.message().find("injected fault"), std::string::npos) << status.message();

  EXPECT_EQ(Slurp(path_), previous_bytes);
  EXPECT_EQ(Files(), std::vector<std::string>{"00042.gsc"});  // temporary removed
  core::ObservationChunk read;
  const Status reread = Read(&read);
  ASSERT_TRUE(reread.ok()) << reread.ToString();
  ExpectBitExact(previous, read);
}

INSTANTIATE_TEST_SUITE_P(
    Faults, ChunkFaultTest,
    ::testing::Values(FaultCase{Operation::kNewWritableFile, 1, "Open"},
                      FaultCase{Operation::kAppend, 1, "FirstAppend"},
                      FaultCase{Operation::kAppend, 7, "MiddleAppend"},
                      FaultCase{Operation::kSync, 1, "Sync"},
                      FaultCase{Operation::kClose, 1, "Close"},
                      FaultCase{Operation::kRename, 1, "Rename"}),
    [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace graphslam::storage
