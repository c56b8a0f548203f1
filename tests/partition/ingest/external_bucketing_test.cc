// External bucketing and the bounded-memory ingest (partition/ingest/external_bucketing.h,
// partition/ingest/streaming_ingest.h): the store equals the in-memory path's, record
// for record; the number of observations held at once is bounded by the
// buffer (a counter, not wall-clock RSS); an interrupted ingest never leaves a
// store that opens, and rerunning it gives the complete store.
#include "partition/ingest/external_bucketing.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <tuple>
#include <vector>

#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "partition/ingest/spill_frames.h"
#include "partition/ingest/streaming_ingest.h"
#include "storage/chunk_store.h"
#include "storage/chunk_writer.h"
#include "storage/compressed_file.h"
#include "storage/env.h"
#include "storage/file_checksum.h"
#include "storage/g2o_writer.h"
#include "storage/native_log_reader.h"
#include "storage/store_directory.h"
#include "tests/testing/directory_bytes.h"
#include "tests/testing/random_problem.h"

namespace graphslam::partition {
namespace {

using storage::Env;
using storage::FaultInjectionEnv;

class ExternalBucketingTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    root_ = std::filesystem::temp_directory_path() /
            ("graphslam_bucketing_" + std::string(info->name()) + "_" + std::to_string(::getpid()));
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(root_);
  }
  void TearDown() override { std::filesystem::remove_all(root_); }
  std::string Path(const std::string& name) const { return (root_ / name).string(); }

  // A random problem with many features seen from many poses, as a native log.
  std::string WriteInput(uint32_t seed, int poses = 150, int features = 80) {
    testing::RandomProblemOptions options;
    options.num_poses = poses;
    options.num_features = features;
    options.seed = seed;
    problem_ = testing::MakeRandomProblem(options).problem;
    const std::string path = Path("input.graphslam");
    EXPECT_TRUE(storage::WriteNativeLog(problem_, path).ok());
    return path;
  }

  // Options that make a small input spill often: chunks of 100, a buffer of
  // 300 observations, a checkpoint at every spill, replay blocks of ~40
  // observations.
  static StreamingIngestOptions SmallSpillOptions() {
    StreamingIngestOptions options;
    options.max_observations_per_chunk = 100;
    options.buffer_observations = 300;
    options.checkpoint_seconds = 0;
    options.replay.frame_observations = 50;  // several frames and segments: mid-spill resume points
    options.replay.frames_per_segment = 3;
    return options;
  }

  // The in-memory path of the previous ingest: read whole, initialize,
  // InMemoryChunkSource, WriteChunkStore.
  void WriteInMemoryStore(const std::string& input, const std::string& store, int64_t chunk) {
    StatusOr<core::Problem2d> read = storage::ReadNativeLog(input);
    ASSERT_TRUE(read.ok()) << read.status().ToString();
    core::Problem2d problem = std::move(read).value();
    ASSERT_TRUE(core::InitializeProblem(&problem).ok());
    ChunkingOptions chunking;
    chunking.max_observations_per_chunk = chunk;
    const InMemoryChunkSource chunks(problem, chunking);
    storage::ChunkStoreWriteOptions options;
    options.source = input;
    StatusOr<storage::FileChecksum> identity = storage::IdentifyInput(input);
    ASSERT_TRUE(identity.ok());
    options.input = *identity;  // as the ingest records it
    ASSERT_TRUE(storage::WriteChunkStore(Env::Default(), store, problem, chunks, options).ok());
  }

  static std::string ReadBytes(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

  static void ExpectSameObservation(const core::Observation& a, const core::Observation& b) {
    EXPECT_EQ(a.pose, b.pose);
    EXPECT_EQ(a.feature, b.feature);
    EXPECT_EQ(a.kind, b.kind);
    EXPECT_EQ(a.z, b.z);
    EXPECT_EQ(a.information, b.information);
    EXPECT_EQ(a.line, b.line);
  }

  // Both stores open and hold the same problem file and the same chunks.
  static void ExpectSameStore(const std::string& a, const std::string& b) {
    EXPECT_EQ(ReadBytes(a + "/problem.graphslam"), ReadBytes(b + "/problem.graphslam"));
    auto sa = storage::DiskChunkSource::Open(a);
    auto sb = storage::DiskChunkSource::Open(b);
    ASSERT_TRUE(sa.ok()) << sa.status().ToString();
    ASSERT_TRUE(sb.ok()) << sb.status().ToString();
    ASSERT_EQ((*sa)->NumChunks(), (*sb)->NumChunks());
    core::ObservationChunk ca, cb;
    for (int64_t k = 0; k < (*sa)->NumChunks(); ++k) {
      ASSERT_TRUE((*sa)->Load(k, &ca).ok());
      ASSERT_TRUE((*sb)->Load(k, &cb).ok());
      EXPECT_EQ(ca.features, cb.features) << "chunk " << k;
      EXPECT_EQ(ca.feature_begin, cb.feature_begin) << "chunk " << k;
      ASSERT_EQ(ca.observations.size(), cb.observations.size()) << "chunk " << k;
      for (size_t i = 0; i < ca.observations.size(); ++i)
        ExpectSameObservation(ca.observations[i], cb.observations[i]);
    }
  }

  static void ExpectSameBytes(const std::string& a, const std::string& b) {
    testing::ExpectSameFiles(testing::FilesUnder(a), testing::FilesUnder(b));
  }
  // As ExpectSameBytes, but for the manifest's record of the input's
  // identity (size and CRC32C of the input file as stored) and the
  // manifest's checksum over it: stores of two different input files.
  static void ExpectSameBytesButInputIdentity(const std::string& a, const std::string& b) {
    std::map<std::string, std::string> files[2] = {testing::FilesUnder(a), testing::FilesUnder(b)};
    for (auto& store : files) {
      nlohmann::json manifest = nlohmann::json::parse(store[storage::kChunkStoreManifestName]);
      manifest.erase("input");
      manifest.erase("checksum");
      store[storage::kChunkStoreManifestName] = manifest.dump();
    }
    testing::ExpectSameFiles(files[0], files[1]);
  }

  core::Problem2d problem_;
  std::filesystem::path root_;
};

TEST_F(ExternalBucketingTest, StoreEqualsTheInMemoryPathForManyBufferSizes) {
  const std::string input = WriteInput(3);
  const int64_t chunk = 100;
  WriteInMemoryStore(input, Path("memory"), chunk);
  for (int64_t buffer : {int64_t{100}, int64_t{137}, int64_t{1} << 20}) {
    SCOPED_TRACE("buffer " + std::to_string(buffer));
    StreamingIngestOptions options;
    options.max_observations_per_chunk = chunk;
    options.buffer_observations = buffer;
    options.store.source = input;
    IngestSummary summary;
    const std::string store = Path("bucketed_" + std::to_string(buffer));
    ASSERT_TRUE(IngestToStore(Env::Default(), input, store, options, &summary).ok());
    EXPECT_TRUE(summary.streamed);
    EXPECT_EQ(summary.observations, static_cast<int64_t>(problem_.observations.size()));
    EXPECT_GT(summary.chunks, 3);
    ExpectSameStore(Path("memory"), store);
    EXPECT_FALSE(std::filesystem::exists(store + "/work")) << "scratch left behind";
  }
}

TEST_F(ExternalBucketingTest, HeldObservationsAreBoundedByTheBufferNotTheInput) {
  const std::string input = WriteInput(5, 300, 200);
  const int64_t total = static_cast<int64_t>(problem_.observations.size());
  std::vector<int64_t> per_feature(problem_.features.size(), 0);
  for (const core::Observation& o : problem_.observations) ++per_feature[o.feature];
  // A feature is never split, so one feature's observations are the floor.
  const int64_t largest = *std::max_element(per_feature.begin(), per_feature.end());
  const int64_t chunk = 64, buffer = 2 * largest;
  ASSERT_GT(total, 10 * buffer) << "the input must be much larger than the buffer";
  StreamingIngestOptions options;
  options.max_observations_per_chunk = chunk;
  options.buffer_observations = buffer;
  IngestSummary summary;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("store"), options, &summary).ok());
  // Every bucket fits the buffer (no feature has more than `buffer`
  // observations); a chunk holds at most max(chunk, largest feature).
  EXPECT_LE(summary.bucketing.peak_observations_in_memory, buffer + std::max(chunk, largest));
  EXPECT_GE(summary.bucketing.peak_observations_in_memory, buffer);
  EXPECT_GE(summary.bucketing.spills, total / buffer);
  EXPECT_GE(summary.bucketing.buckets, total / buffer);
  EXPECT_EQ(summary.bucketing.observations, total);
}

TEST_F(ExternalBucketingTest, NonNativeInputIsReplayedFromMemoryWithTheSameChunks) {
  // A g2o input (point observations): read whole, then bucketed.
  testing::RandomProblemOptions random;
  random.num_poses = 200;
  random.num_features = 60;
  random.range_bearing = false;
  random.seed = 9;
  const core::Problem2d problem = testing::MakeRandomProblem(random).problem;
  const std::string input = Path("input.g2o");
  ASSERT_TRUE(storage::WriteG2o(problem, input).ok());
  StreamingIngestOptions options;
  options.format = storage::InputFormat::kG2o;
  options.max_observations_per_chunk = 50;
  options.buffer_observations = 70;
  IngestSummary summary;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("store"), options, &summary).ok());
  EXPECT_FALSE(summary.streamed);

  StatusOr<core::Problem2d> read = storage::ReadProblem(input, storage::InputFormat::kG2o, {});
  ASSERT_TRUE(read.ok());
  core::Problem2d whole = std::move(read).value();
  ASSERT_TRUE(core::InitializeProblem(&whole).ok());
  ChunkingOptions chunking;
  chunking.max_observations_per_chunk = 50;
  const InMemoryChunkSource expected(whole, chunking);
  auto store = storage::DiskChunkSource::Open(Path("store"));
  ASSERT_TRUE(store.ok());
  ASSERT_EQ((*store)->NumChunks(), expected.NumChunks());
  core::ObservationChunk a, b;
  for (int64_t k = 0; k < expected.NumChunks(); ++k) {
    ASSERT_TRUE((*store)->Load(k, &a).ok());
    ASSERT_TRUE(expected.Load(k, &b).ok());
    EXPECT_EQ(a.features, b.features);
    ASSERT_EQ(a.observations.size(), b.observations.size());
    for (size_t i = 0; i < a.observations.size(); ++i)
      ExpectSameObservation(a.observations[i], b.observations[i]);
  }
}

// The features of the log have no guesses and the observations come
// shuffled, so the store's feature guesses are Table 1's placement by each
// feature's first sight in input order (first sights spilled to disk in pass
// 1, partition/initialization/first_sight_initialization.h), not by its lowest pose: the
// problem file equals the in-memory path's byte for byte.
TEST_F(ExternalBucketingTest, FeatureGuessesOfTheStoreAreTable1OnEveryObservation) {
  testing::RandomProblemOptions random;
  random.num_poses = 150;
  random.num_features = 80;
  random.seed = 12;
  problem_ = testing::MakeRandomProblem(random).problem;
  std::fill(problem_.feature_initialized.begin(), problem_.feature_initialized.end(), 0);
  std::mt19937 rng(12);
  std::shuffle(problem_.observations.begin(), problem_.observations.end(), rng);
  const std::string input = Path("input.graphslam");
  ASSERT_TRUE(storage::WriteNativeLog(problem_, input).ok());
  StatusOr<core::Problem2d> read = storage::ReadNativeLog(input);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  // The log keeps the shuffled order: some feature is first seen from a pose
  // above its lowest.
  std::vector<int32_t> first_seen(read->num_features(), -1), lowest(read->num_features(), 1 << 30);
  for (const core::Observation& o : read->observations) {
    if (first_seen[o.feature] < 0) first_seen[o.feature] = o.pose;
    lowest[o.feature] = std::min(lowest[o.feature], o.pose);
  }
  EXPECT_NE(first_seen, lowest);
  for (uint8_t initialized : read->feature_initialized) ASSERT_EQ(initialized, 0);

  const int64_t chunk = 100;
  WriteInMemoryStore(input, Path("memory"), chunk);
  StreamingIngestOptions options;
  options.max_observations_per_chunk = chunk;
  options.buffer_observations = 137;
  options.store.source = input;
  IngestSummary summary;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("streamed"), options, &summary).ok());
  ExpectSameStore(Path("memory"), Path("streamed"));
  EXPECT_FALSE(std::filesystem::exists(Path("streamed") + "/work")) << "scratch left behind";

  StatusOr<core::Problem2d> stored =
      storage::ReadNativeLog(Path("streamed") + "/problem.graphslam");
  ASSERT_TRUE(stored.ok()) << stored.status().ToString();
  core::Problem2d all = std::move(read).value();
  ASSERT_TRUE(core::InitializeProblem(&all).ok());
  ASSERT_EQ(stored->num_features(), all.num_features());
  for (int32_t f = 0; f < all.num_features(); ++f)
    EXPECT_EQ(stored->features[f], all.features[f]) << "feature " << f;
}

// A run killed in pass 1 leaves a partial work/first_sight.bin and no
// progress record: --resume starts afresh (emptying work/), the scratch of the
// dead run never reaches the guesses, and nothing is left behind.
TEST_F(ExternalBucketingTest, FirstSightScratchOfAKilledPassOneIsDiscarded) {
  const std::string input = WriteInput(13);
  const int64_t chunk = 100;
  WriteInMemoryStore(input, Path("memory"), chunk);
  const std::string store = Path("streamed");
  // A store folder of ours (the marker is the first thing an ingest writes).
  ASSERT_TRUE(storage::ClaimStoreDirectory(Env::Default(), store).ok());
  std::filesystem::create_directories(store + "/work");
  {
    std::ofstream stale(store + "/work/first_sight.bin", std::ios::binary);
    stale << std::string(1000, '\x7f');  // not even whole records
  }
  StreamingIngestOptions options;
  options.max_observations_per_chunk = chunk;
  options.buffer_observations = 137;
  options.store.source = input;
  options.resume = true;
  IngestSummary summary;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, store, options, &summary).ok());
  EXPECT_EQ(summary.resumed_stage, "");
  ExpectSameBytes(Path("memory"), store);
  EXPECT_FALSE(std::filesystem::exists(store + "/work")) << "scratch left behind";
}

TEST_F(ExternalBucketingTest, FailedIngestNeverLeavesAStoreThatOpensAndRerunCompletesIt) {
  const std::string input = WriteInput(11);
  const std::string store = Path("store");
  StreamingIngestOptions options;
  options.max_observations_per_chunk = 100;
  options.buffer_observations = 150;
  IngestSummary summary;
  // A complete store first: a failed re-ingest must un-commit it too.
  ASSERT_TRUE(IngestToStore(Env::Default(), input, store, options, &summary).ok());
  const int64_t chunks = summary.chunks;
  ASSERT_GT(chunks, 2);
  // Fail the k-th durable rename: the problem file (1), a chunk, the manifest.
  for (int nth : {1, static_cast<int>(chunks), static_cast<int>(chunks) + 2}) {
    SCOPED_TRACE("rename " + std::to_string(nth));
    FaultInjectionEnv env(Env::Default());
    env.FailAt(FaultInjectionEnv::Operation::kRename, nth);
    EXPECT_FALSE(IngestToStore(&env, input, store, options, &summary).ok());
    EXPECT_FALSE(storage::IsChunkStore(store));
    auto opened = storage::DiskChunkSource::Open(store);
    ASSERT_FALSE(opened.ok());
    EXPECT_NE(opened.status().ToString().find("incomplete chunk store"), std::string::npos)
        << opened.status().ToString();
  }
  // Rerun: complete, and the same as a fresh ingest.
  ASSERT_TRUE(IngestToStore(Env::Default(), input, store, options, &summary).ok());
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("fresh"), options, &summary).ok());
  ExpectSameStore(store, Path("fresh"));
}

TEST_F(ExternalBucketingTest, ReplayThatDiffersFromTheFirstPassIsCorruption) {
  FeatureIndex index;
  core::Observation o;
  o.pose = 0;
  o.feature = 0;
  index.Add(o);
  index.Add(o);
  ExternalBucketingOptions options;
  options.max_observations_per_chunk = 4;
  options.buffer_observations = 4;
  options.work_dir = Path("");
  // Second pass gives one observation of feature 0 only: counts differ.
  auto short_replay = [&](const storage::ObservationSink& sink) { return sink(o); };
  auto built = BucketChunkSource::Build(index, short_replay, options);
  ASSERT_FALSE(built.ok());
  EXPECT_NE(built.status().ToString().find("the first pass counted 2"), std::string::npos)
      << built.status().ToString();
  // ... or a feature pass 1 never saw.
  core::Observation unseen = o;
  unseen.feature = 5;
  auto unseen_replay = [&](const storage::ObservationSink& sink) { return sink(unseen); };
  built = BucketChunkSource::Build(index, unseen_replay, options);
  ASSERT_FALSE(built.ok());
  EXPECT_NE(built.status().ToString().find("was not seen in the first"), std::string::npos);
}

}  // namespace
}  // namespace graphslam::partition

namespace graphslam::partition {
namespace {

// The parallel, group-synced chunk writer (ChunkStoreWriter) writes the bytes
// that WriteObservationChunk writes file by file, with and without zstd.
TEST_F(ExternalBucketingTest, ChunkFilesAreByteIdenticalToTheOneFileAtATimeWriter) {
  const std::string input = WriteInput(13);
  for (const bool compress : {false, true}) {
    SCOPED_TRACE(compress ? "zstd" : "raw");
    StreamingIngestOptions options;
    options.max_observations_per_chunk = 90;
    options.buffer_observations = 200;
    options.store.sync_group_chunks = 3;
    if (compress) options.store.chunk.compression = storage::ChunkCompression::kZstd;
    const std::string store = Path(compress ? "zstd" : "raw");
    IngestSummary summary;
    ASSERT_TRUE(IngestToStore(Env::Default(), input, store, options, &summary).ok());
    ASSERT_GT(summary.chunks, 6);

    StatusOr<core::Problem2d> read = storage::ReadNativeLog(input);
    ASSERT_TRUE(read.ok());
    core::Problem2d problem = std::move(read).value();
    ASSERT_TRUE(core::InitializeProblem(&problem).ok());
    ChunkingOptions chunking;
    chunking.max_observations_per_chunk = 90;
    const InMemoryChunkSource chunks(problem, chunking);
    ASSERT_EQ(chunks.NumChunks(), summary.chunks);
    core::ObservationChunk chunk;
    for (int64_t k = 0; k < chunks.NumChunks(); ++k) {
      ASSERT_TRUE(chunks.Load(k, &chunk).ok());
      const std::string expected = Path("expected.gsc");
      ASSERT_TRUE(
          storage::WriteObservationChunk(Env::Default(), expected, chunk, options.store.chunk).ok());
      EXPECT_TRUE(ReadBytes(expected) ==
                  ReadBytes(store + "/chunks/" + storage::ChunkStoreFileName(k)))
          << "chunk " << k;
    }
  }
}

// Env::Default() without fsyncs: the resume test runs a dozen ingests, and on
// a loaded machine their fsyncs, not their work, would take the time. What a
// resume reads is the same either way (the files are closed and renamed).
class NoSyncEnv final : public Env {
 public:
  StatusOr<std::unique_ptr<storage::WritableFile>> NewWritableFile(
      const std::string& path) override {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<storage::WritableFile> file,
                        Env::Default()->NewWritableFile(path));
    return std::unique_ptr<storage::WritableFile>(std::make_unique<File>(std::move(file)));
  }
  Status Rename(const std::string& from, const std::string& to) override {
    return Env::Default()->Rename(from, to);
  }
  Status RemoveFile(const std::string& path) override { return Env::Default()->RemoveFile(path); }
  bool FileExists(const std::string& path) override { return Env::Default()->FileExists(path); }
  Status SyncDirectory(const std::string&) override { return Status::Ok(); }
  storage::FileKind KindOf(const std::string& path) override {
    return Env::Default()->KindOf(path);
  }
  StatusOr<std::string> ResolvePath(const std::string& path) override {
    return Env::Default()->ResolvePath(path);
  }
  StatusOr<std::unique_ptr<storage::WritableFile>> OpenStream(const std::string& path) override {
    return Env::Default()->OpenStream(path);
  }

 private:
  class File final : public storage::WritableFile {
   public:
    explicit File(std::unique_ptr<storage::WritableFile> base) : base_(std::move(base)) {}
    Status Append(std::string_view data) override { return base_->Append(data); }
    Status Sync() override { return Status::Ok(); }
    Status Close() override { return base_->Close(); }

   private:
    std::unique_ptr<storage::WritableFile> base_;
  };
};

// An ingest that dies at a durable step (the n-th rename: problem file,
// first-pass record, a progress record, a chunk file, the manifest) and is
// then resumed gives the uninterrupted ingest's store, byte for byte; the
// resumes start in the second pass and in the chunk stage.
TEST_F(ExternalBucketingTest, ResumeAfterDyingAtDurableStepsGivesTheSameStoreBytes) {
  const std::string input = WriteInput(17, 150, 80);
  StreamingIngestOptions options = SmallSpillOptions();
  options.store.sync_group_chunks = 4;
  options.store.source = input;
  IngestSummary summary;
  NoSyncEnv no_sync;
  FaultInjectionEnv counting(&no_sync);
  ASSERT_TRUE(IngestToStore(&counting, input, Path("full"), options, &summary).ok());
  const int renames = counting.Count(FaultInjectionEnv::Operation::kRename);
  ASSERT_GE(summary.bucketing.spills, 4);
  ASSERT_GE(summary.chunks, 12);
  // Renames: problem, pass1.bin, progress "spill", one progress per spill
  // checkpoint, progress "chunks", then chunk files and a progress per group,
  // the manifest. Every step up to the 7th, then five spread over the rest.
  std::vector<int> steps = {1, 2, 3, 4, 5, 6, 7};
  for (int i = 1; i <= 5; ++i) steps.push_back(7 + i * (renames - 8) / 5);
  std::map<std::string, int> resumed_stages;
  for (const int nth : steps) {
    SCOPED_TRACE("dies at rename " + std::to_string(nth) + " of " + std::to_string(renames));
    const std::string store = Path("store");
    std::filesystem::remove_all(store);
    FaultInjectionEnv env(&no_sync);
    env.FailAt(FaultInjectionEnv::Operation::kRename, nth);
    ASSERT_FALSE(IngestToStore(&env, input, store, options, &summary).ok());
    EXPECT_FALSE(storage::IsChunkStore(store));
    StreamingIngestOptions resume = options;
    resume.resume = true;
    ASSERT_TRUE(IngestToStore(&no_sync, input, store, resume, &summary).ok());
    ++resumed_stages[summary.resumed_stage];
    ExpectSameBytes(store, Path("full"));
  }
  EXPECT_GE(resumed_stages["spill"], 3);
  EXPECT_GE(resumed_stages["chunks"], 3);
  EXPECT_GE(resumed_stages[""], 2);  // died before the first record: afresh
}

// A kill in the middle of a spill leaves a torn frame (and whole frames the
// progress record does not count) at the end of bucket files: the resume
// truncates them back to the recorded frame boundary and gives the same store.
// A damaged frame inside the recorded part is Corruption naming the bucket
// file and the frame's byte offset.
TEST_F(ExternalBucketingTest, ResumeAfterATornSpillFrameGivesTheSameStoreBytes) {
  const std::string input = WriteInput(29, 150, 80);
  StreamingIngestOptions options = SmallSpillOptions();
  options.store.source = input;
  IngestSummary summary;
  NoSyncEnv no_sync;
  ASSERT_TRUE(IngestToStore(&no_sync, input, Path("full"), options, &summary).ok());
  ASSERT_GE(summary.bucketing.spills, 4);
  EXPECT_LT(summary.bucketing.spilled_bytes, summary.bucketing.spilled_raw_bytes);

  const std::string store = Path("store");
  const std::string bucket = (std::filesystem::path(store) / "work" / "bucket_000000.bin").string();
  auto die_in_the_spill = [&]() {
    std::filesystem::remove_all(store);
    FaultInjectionEnv env(&no_sync);
    // Rename 1 is the folder's marker (storage/store_directory.h); 6 is the
    // second spill checkpoint.
    env.FailAt(FaultInjectionEnv::Operation::kRename, 6);
    ASSERT_FALSE(IngestToStore(&env, input, store, options, &summary).ok());
    ASSERT_TRUE(std::filesystem::exists(bucket));
  };
  StreamingIngestOptions resume = options;
  resume.resume = true;

  // The replay segments behind the first checkpoint (300 observations: two
  // segments of 150) are gone, the later ones are there for the resume; a
  // damaged one is Corruption naming it and the frame's offset.
  die_in_the_spill();
  const std::filesystem::path work = std::filesystem::path(store) / "work";
  EXPECT_FALSE(std::filesystem::exists(work / "replay_000000.bin"));
  EXPECT_FALSE(std::filesystem::exists(work / "replay_000001.bin"));
  const std::string replay = (work / "replay_000003.bin").string();
  ASSERT_TRUE(std::filesystem::exists(replay));
  {
    std::string bytes = ReadBytes(replay);
    bytes[kSpillFrameHeaderBytes + 1] ^= 0x04;
    std::ofstream(replay, std::ios::binary | std::ios::trunc) << bytes;
    const Status status = IngestToStore(&no_sync, input, store, resume, &summary);
    ASSERT_FALSE(status.ok());
    EXPECT_TRUE(status.IsCorruption()) << status.ToString();
    EXPECT_NE(status.message().find(replay + ": spill frame at byte 0: CRC mismatch"),
              std::string::npos)
        << status.ToString();
    EXPECT_FALSE(storage::IsChunkStore(store));
  }

  die_in_the_spill();
  const std::string frame_start = ReadBytes(bucket).substr(0, 20);
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(store) / "work"))
    if (entry.path().filename().string().rfind("bucket_", 0) == 0)
      std::ofstream(entry.path(), std::ios::binary | std::ios::app) << frame_start;  // torn
  ASSERT_TRUE(IngestToStore(&no_sync, input, store, resume, &summary).ok());
  EXPECT_EQ(summary.resumed_stage, "spill");
  ExpectSameBytes(store, Path("full"));

  die_in_the_spill();
  std::string bytes = ReadBytes(bucket);
  bytes[kSpillFrameHeaderBytes + 3] ^= 0x10;
  std::ofstream(bucket, std::ios::binary | std::ios::trunc) << bytes;
  const Status status = IngestToStore(&no_sync, input, store, resume, &summary);
  ASSERT_FALSE(status.ok());
  EXPECT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_NE(status.message().find(bucket + ": spill frame at byte 0: CRC mismatch"),
            std::string::npos)
      << status.ToString();
  EXPECT_FALSE(storage::IsChunkStore(store));
}

// Bucket runs longer than one spill frame (kMaxSpillFrameObservations) are
// written as several frames and read back whole: every chunk has its
// features' observations, each feature's in input order, bit for bit.
TEST_F(ExternalBucketingTest, RunsLongerThanOneFrameReadBackInInputOrder) {
  const int64_t total = 3 * static_cast<int64_t>(kMaxSpillFrameObservations) + 123;
  std::vector<core::Observation> input(static_cast<size_t>(total));
  std::mt19937 rng(31);
  FeatureIndex index;
  for (int64_t i = 0; i < total; ++i) {
    core::Observation& o = input[static_cast<size_t>(i)];
    o.pose = static_cast<int32_t>(i / 100);
    o.feature = static_cast<int32_t>(rng() % 2000);
    o.z = {std::ldexp(static_cast<double>(rng()), -7), -static_cast<double>(i)};
    o.line = static_cast<int32_t>(i + 1);  // input order
    index.Add(o);
  }
  ExternalBucketingOptions options;
  options.max_observations_per_chunk = 50000;
  options.buffer_observations = total;  // one spill: runs of ~50000-200000
  options.work_dir = Path("work");
  std::filesystem::create_directories(options.work_dir);
  const ObservationReplay replay = [&](const storage::ObservationSink& sink) -> Status {
    for (const core::Observation& o : input) GS_RETURN_IF_ERROR(sink(o));
    return Status::Ok();
  };
  StatusOr<std::unique_ptr<BucketChunkSource>> source = BucketChunkSource::Build(index, replay, options);
  ASSERT_TRUE(source.ok()) << source.status().ToString();
  EXPECT_EQ((*source)->stats().spills, 1);
  EXPECT_LT((*source)->stats().spilled_bytes, (*source)->stats().spilled_raw_bytes / 2);
  int64_t seen = 0;
  core::ObservationChunk chunk;
  for (int64_t k = 0; k < (*source)->NumChunks(); ++k) {
    ASSERT_TRUE((*source)->Load(k, &chunk).ok());
    for (size_t i = 0; i < chunk.observations.size(); ++i) {
      const core::Observation& o = chunk.observations[i];
      const core::Observation& original = input[static_cast<size_t>(o.line - 1)];
      ASSERT_EQ(o.feature, original.feature);
      ASSERT_EQ(o.pose, original.pose);
      ASSERT_EQ(o.z, original.z);
      if (i > 0 && chunk.observations[i - 1].feature == o.feature) {
        ASSERT_LT(chunk.observations[i - 1].line, o.line);  // input order kept
      }
    }
    seen += static_cast<int64_t>(chunk.observations.size());
  }
  EXPECT_EQ(seen, total);
}

// Many spills, each overlapping the next buffer's fill (the spill's frames
// are encoded and appended in the background), into buckets of many frames,
// grouped in parallel: every chunk holds exactly its features'
// observations, feature by feature in the chunk's order and each feature's
// in input order (against the input itself), and the chunks are the same
// with one thread as with the pool.
TEST_F(ExternalBucketingTest, OverlappedSpillsAndParallelGroupingKeepInputOrder) {
  const int64_t total = 300000;
  const int32_t features = 5000;
  std::vector<core::Observation> input(static_cast<size_t>(total));
  std::vector<std::vector<int64_t>> of_feature(features);  // input positions per feature
  std::mt19937 rng(47);
  FeatureIndex index;
  for (int64_t i = 0; i < total; ++i) {
    core::Observation& o = input[static_cast<size_t>(i)];
    o.pose = static_cast<int32_t>(i / 60);
    // Skewed and local: features near the pose's, a few far ones.
    o.feature = static_cast<int32_t>((i / 60 + rng() % (rng() % 8 == 0 ? features : 40)) %
                                     features);
    o.z = {std::ldexp(static_cast<double>(rng()), -9), static_cast<double>(i)};
    o.line = static_cast<int32_t>(i + 1);
    of_feature[static_cast<size_t>(o.feature)].push_back(i);
    index.Add(o);
  }
  const ObservationReplay replay = [&](const storage::ObservationSink& sink) -> Status {
    for (const core::Observation& o : input) GS_RETURN_IF_ERROR(sink(o));
    return Status::Ok();
  };
  // The chunks of a source built with `threads` threads (0: the pool).
  const auto build = [&](const std::string& work, int threads) {
    std::unique_ptr<tbb::global_control> limit;
    if (threads > 0)
      limit = std::make_unique<tbb::global_control>(
          tbb::global_control::max_allowed_parallelism, static_cast<size_t>(threads));
    ExternalBucketingOptions options;
    options.max_observations_per_chunk = 3000;
    options.buffer_observations = 20000;  // ~15 spills, ~15 buckets of ~15 frames
    options.work_dir = Path(work);
    std::filesystem::create_directories(options.work_dir);
    StatusOr<std::unique_ptr<BucketChunkSource>> source =
        BucketChunkSource::Build(index, replay, options);
    EXPECT_TRUE(source.ok()) << source.status().ToString();
    std::vector<core::ObservationChunk> chunks;
    if (!source.ok()) return chunks;
    EXPECT_GE((*source)->stats().spills, 14);
    EXPECT_GE((*source)->NumBuckets(), 10);
    for (int64_t k = 0; k < (*source)->NumChunks(); ++k) {
      chunks.emplace_back();
      EXPECT_TRUE((*source)->Load(k, &chunks.back()).ok());
    }
    return chunks;
  };
  const std::vector<core::ObservationChunk> pool = build("work_pool", 0);
  const std::vector<core::ObservationChunk> serial = build("work_serial", 1);
  ASSERT_EQ(pool.size(), serial.size());
  ASSERT_GT(pool.size(), 50u);
  std::vector<int> chunk_of(features, -1);
  int64_t seen = 0;
  for (size_t k = 0; k < pool.size(); ++k) {
    const core::ObservationChunk& chunk = pool[k];
    // The plan's feature order, each feature's observations in input order.
    std::vector<int64_t> expected;
    for (const int32_t f : chunk.features) {
      ASSERT_EQ(chunk_of[static_cast<size_t>(f)], -1) << "feature " << f << " in two chunks";
      chunk_of[static_cast<size_t>(f)] = static_cast<int>(k);
      const std::vector<int64_t>& positions = of_feature[static_cast<size_t>(f)];
      expected.insert(expected.end(), positions.begin(), positions.end());
    }
    ASSERT_EQ(chunk.observations.size(), expected.size()) << "chunk " << k;
    ASSERT_EQ(serial[k].features, chunk.features) << "chunk " << k;
    ASSERT_EQ(serial[k].feature_begin, chunk.feature_begin) << "chunk " << k;
    ASSERT_EQ(serial[k].observations.size(), expected.size()) << "chunk " << k;
    for (size_t i = 0; i < expected.size(); ++i) {
      const core::Observation& original = input[static_cast<size_t>(expected[i])];
      ASSERT_EQ(chunk.observations[i].line, original.line) << "chunk " << k << " at " << i;
      ExpectSameObservation(chunk.observations[i], original);
      ExpectSameObservation(serial[k].observations[i], original);
    }
    seen += static_cast<int64_t>(expected.size());
  }
  EXPECT_EQ(seen, total);
}

// RestrictSpillToChunks (an ingest on MPI ranks, partition/ingest/streaming_ingest.h):
// each of three shards spills only the buckets its chunks are cut from, far
// fewer observations than the input, and loads its chunks exactly as the
// unrestricted source does.
TEST_F(ExternalBucketingTest, ShardSpillsOnlyItsBucketsAndCutsTheSameChunks) {
  std::vector<core::Observation> input;
  std::mt19937 rng(5);
  FeatureIndex index;
  for (int32_t i = 0; i < 6000; ++i) {
    core::Observation o;
    o.pose = i / 20;
    o.feature = static_cast<int32_t>((i / 20 + rng() % 8) % 700);
    o.z = {static_cast<double>(rng() % 1000), static_cast<double>(i)};
    o.line = i + 1;
    input.push_back(o);
    index.Add(o);
  }
  const ObservationReplay replay = [&](const storage::ObservationSink& sink) -> Status {
    for (const core::Observation& o : input) GS_RETURN_IF_ERROR(sink(o));
    return Status::Ok();
  };
  ExternalBucketingOptions options;
  options.max_observations_per_chunk = 100;
  options.buffer_observations = 300;
  options.work_dir = Path("all");
  std::filesystem::create_directories(options.work_dir);
  StatusOr<std::unique_ptr<BucketChunkSource>> all = BucketChunkSource::Build(index, replay, options);
  ASSERT_TRUE(all.ok()) << all.status().ToString();
  const int64_t chunks = (*all)->NumChunks();
  ASSERT_GE((*all)->NumBuckets(), 9);
  const auto bucket_files = [](const std::string& dir) {
    int64_t n = 0;
    for (const auto& entry : std::filesystem::directory_iterator(dir))
      n += entry.path().filename().string().rfind("bucket_", 0) == 0 ? 1 : 0;
    return n;
  };
  EXPECT_EQ(bucket_files(options.work_dir), (*all)->NumBuckets());
  int64_t spilled = 0;
  for (int rank = 0; rank < 3; ++rank) {
    SCOPED_TRACE("shard " + std::to_string(rank));
    options.work_dir = Path("shard" + std::to_string(rank));
    std::filesystem::create_directories(options.work_dir);
    StatusOr<std::unique_ptr<BucketChunkSource>> shard = BucketChunkSource::Plan(index, options);
    ASSERT_TRUE(shard.ok());
    const int64_t begin = chunks * rank / 3, end = chunks * (rank + 1) / 3;
    (*shard)->RestrictSpillToChunks(begin, end);
    SpillProgress progress;
    ASSERT_TRUE((*shard)->Spill(InBlocks(replay), &progress, {}, 0.0).ok());
    const int64_t mine = (*shard)->stats().spilled_raw_bytes /
                         static_cast<int64_t>(sizeof(core::Observation));
    EXPECT_LT(mine, static_cast<int64_t>(input.size()) / 2);
    EXPECT_LT(bucket_files(options.work_dir), (*all)->NumBuckets() / 2);
    spilled += mine;
    core::ObservationChunk a, b;
    for (int64_t k = begin; k < end; ++k) {
      ASSERT_TRUE((*all)->Load(k, &a).ok());
      ASSERT_TRUE((*shard)->Load(k, &b).ok());
      EXPECT_EQ(b.features, a.features) << "chunk " << k;
      EXPECT_EQ(b.feature_begin, a.feature_begin) << "chunk " << k;
      ASSERT_EQ(b.observations.size(), a.observations.size()) << "chunk " << k;
      for (size_t i = 0; i < a.observations.size(); ++i)
        ExpectSameObservation(b.observations[i], a.observations[i]);
    }
  }
  // Every observation at least once; a bucket on a shard boundary twice.
  EXPECT_GE(spilled, static_cast<int64_t>(input.size()));
  EXPECT_LE(spilled, static_cast<int64_t>(input.size()) + 2 * 300);
}

// A resume whose input changed since the interrupted ingest starts afresh
// (and still gives the right store).
TEST_F(ExternalBucketingTest, ResumeWithAChangedInputStartsAfresh) {
  std::string input = WriteInput(19);
  StreamingIngestOptions options;
  options.max_observations_per_chunk = 60;
  options.buffer_observations = 100;
  options.checkpoint_seconds = 0;
  IngestSummary summary;
  FaultInjectionEnv env(Env::Default());
  env.FailAt(FaultInjectionEnv::Operation::kRename, 6);
  ASSERT_FALSE(IngestToStore(&env, input, Path("store"), options, &summary).ok());
  input = WriteInput(23);  // same path, other contents
  options.resume = true;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("store"), options, &summary).ok());
  EXPECT_EQ(summary.resumed_stage, "");
  options.resume = false;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("fresh"), options, &summary).ok());
  ExpectSameBytes(Path("store"), Path("fresh"));
}

// A zstd-compressed native log (graphslam simulate --streaming --compress)
// ingests into the very store of the plain log, byte for byte, also when the
// ingest dies in pass 2 and resumes (its offsets are decompressed offsets); a
// truncated or corrupted .zst is an error naming the file and the offset.
// The sizes of a counts trailer (tools/memory_budget.h IngestInput::Expected)
// only reserve pass 1's arrays: exact, too small or too large, the store's
// bytes are those of an ingest without them.
TEST_F(ExternalBucketingTest, ExpectedSizesGiveTheSameStoreBytes) {
  const std::string input = WriteInput(31, 150, 80);
  StreamingIngestOptions options = SmallSpillOptions();
  IngestSummary summary;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("plain"), options, &summary).ok());
  const int64_t features = summary.features;
  ASSERT_GT(features, 10);
  int run = 0;
  for (const storage::ExpectedSizes expected :
       {storage::ExpectedSizes{features, 4 * features}, storage::ExpectedSizes{3, 5},
        storage::ExpectedSizes{100 * features, 1000 * features}}) {
    options.expected = expected;
    const std::string store = Path("expected" + std::to_string(run++));
    ASSERT_TRUE(IngestToStore(Env::Default(), input, store, options, &summary).ok());
    ExpectSameBytesButInputIdentity(store, Path("plain"));
  }
}

TEST_F(ExternalBucketingTest, ZstdInputGivesThePlainInputsStoreBytesAndResumes) {
  const std::string input = WriteInput(29, 150, 80);
  StreamingIngestOptions options = SmallSpillOptions();
  IngestSummary summary;
  ASSERT_TRUE(IngestToStore(Env::Default(), input, Path("plain"), options, &summary).ok());
  // The same path, now compressed (problem.graphslam names its input path):
  // detected by its magic number, not by its name.
  const std::string zst = input;
  const std::string text = ReadBytes(input);
  {
    auto file = Env::Default()->NewWritableFile(zst);
    ASSERT_TRUE(file.ok());
    storage::ZstdWriter writer(file->get(), 3);
    ASSERT_TRUE(writer.Append(text).ok());
    ASSERT_TRUE(writer.Finish().ok());
    ASSERT_TRUE((*file)->Close().ok());
  }
  ASSERT_TRUE(storage::IsZstdFile(zst));
  const Status zstd_ingest = IngestToStore(Env::Default(), zst, Path("zstd"), options, &summary);
  ASSERT_TRUE(zstd_ingest.ok()) << zstd_ingest.ToString();
  ExpectSameBytesButInputIdentity(Path("zstd"), Path("plain"));

  // Dies at the 6th rename (the marker, then a pass-2 checkpoint), resumes
  // mid-stream.
  FaultInjectionEnv env(Env::Default());
  env.FailAt(FaultInjectionEnv::Operation::kRename, 6);
  ASSERT_FALSE(IngestToStore(&env, zst, Path("resumed"), options, &summary).ok());
  StreamingIngestOptions resume = options;
  resume.resume = true;
  ASSERT_TRUE(IngestToStore(Env::Default(), zst, Path("resumed"), resume, &summary).ok());
  EXPECT_EQ(summary.resumed_stage, "spill");
  EXPECT_GT(summary.resumed_from_observation, 0);
  ExpectSameBytesButInputIdentity(Path("resumed"), Path("plain"));

  // Truncated: the error names the file and where it ends.
  const std::string bytes = ReadBytes(zst);
  const std::string cut = Path("cut.graphslam.zst");
  std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() - 7);
  Status status = IngestToStore(Env::Default(), cut, Path("cut"), options, &summary);
  EXPECT_EQ(status.code(), Status::Code::kCorruption) << status.ToString();
  EXPECT_NE(status.message().find(cut + ": truncated zstd stream"), std::string::npos)
      << status.ToString();
  EXPECT_NE(status.message().find("compressed offset " + std::to_string(bytes.size() - 7)),
            std::string::npos)
      << status.ToString();
  EXPECT_FALSE(storage::IsChunkStore(Path("cut")));
  // Corrupted in the middle.
  std::string flipped = bytes;
  flipped[bytes.size() / 2] = static_cast<char>(flipped[bytes.size() / 2] ^ 0x41);
  const std::string bad = Path("bad.graphslam.zst");
  std::ofstream(bad, std::ios::binary) << flipped;
  status = IngestToStore(Env::Default(), bad, Path("bad"), options, &summary);
  EXPECT_EQ(status.code(), Status::Code::kCorruption) << status.ToString();
  EXPECT_NE(status.message().find(bad + ": corrupt zstd data"), std::string::npos)
      << status.ToString();
  EXPECT_FALSE(storage::IsChunkStore(Path("bad")));
}

}  // namespace
}  // namespace graphslam::partition
