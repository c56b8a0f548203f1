// Integrity of a chunk store (docs/formats/chunk_store.md, version 2; issue
// 22, defect 3): every damage or edit of any file is Corruption naming the
// file -- a deleted or changed line of problem.graphslam, a manifest edited
// down to fewer chunks (with its counts made consistent by hand), a changed
// digit in the manifest, a changed byte in a chunk or a scans file -- and a
// version 1 store (no checksums) is still read.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/checksummed_json.h"
#include "storage/chunk_store.h"
#include "storage/chunk_store_writer.h"
#include "storage/crc32c.h"
#include "storage/file_checksum.h"
#include "storage/store_directory.h"
#include "tests/testing/random_problem.h"

namespace graphslam::storage {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

std::string Read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void Write(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// The stores' problem (60 poses, 40 features, initialized) and chunking.
core::Problem2d StoreProblem() {
  testing::RandomProblemOptions options;
  options.num_poses = 60;
  options.num_features = 40;
  options.seed = 5;
  core::Problem2d problem = testing::MakeRandomProblem(options).problem;
  EXPECT_TRUE(core::InitializeProblem(&problem).ok());
  return problem;
}
partition::ChunkingOptions StoreChunking() {
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = 20;
  return chunking;
}

class ChunkStoreIntegrity : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("chunk_store_integrity_" + std::to_string(::getpid()) +
                                        "_" + ::testing::UnitTest::GetInstance()
                                                  ->current_test_info()
                                                  ->name());
    fs::remove_all(dir_);
    // A scans file present before the commit is listed (as IngestScans
    // leaves them), in a folder claimed as ours first (as the ingest does).
    ASSERT_TRUE(ClaimStoreDirectory(Env::Default(), dir_.string()).ok());
    Write(dir_ / "scans" / "SCANS.json", "{\"format\": \"graphslam-scan-store\"}\n");
    const core::Problem2d problem = StoreProblem();
    partition::InMemoryChunkSource chunks(problem, StoreChunking());
    ChunkStoreWriteOptions write;
    write.source = "input.graphslam";
    write.input = FileChecksum{1234, 0xdeadbeef};
    ASSERT_TRUE(WriteChunkStore(Env::Default(), dir_.string(), problem, chunks, write).ok());
  }
  void TearDown() override { fs::remove_all(dir_); }

  // Opens the store and reads everything a solve reads.
  Status ReadAll() const {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<DiskChunkSource> store, DiskChunkSource::Open(dir_.string()));
    GS_RETURN_IF_ERROR(ReadChunkStoreProblem(dir_.string()).status());
    core::ObservationChunk chunk;
    for (int64_t k = 0; k < store->NumChunks(); ++k) GS_RETURN_IF_ERROR(store->Load(k, &chunk));
    return VerifyChunkStoreFiles(dir_.string(), "scans/");
  }

  fs::path Manifest() const { return dir_ / kChunkStoreManifestName; }
  fs::path Problem() const { return dir_ / kChunkStoreProblemName; }

  fs::path dir_;
};

TEST_F(ChunkStoreIntegrity, IntactStoreReadsAndRecordsItsInput) {
  ASSERT_TRUE(ReadAll().ok()) << ReadAll().ToString();
  StatusOr<std::unique_ptr<DiskChunkSource>> store = DiskChunkSource::Open(dir_.string());
  ASSERT_TRUE(store.ok());
  EXPECT_EQ((*store)->version(), kChunkStoreVersion);
  EXPECT_EQ((*store)->input(), (FileChecksum{1234, 0xdeadbeef}));
  ASSERT_EQ((*store)->files().size(), 2u);
  EXPECT_EQ((*store)->files()[0].path, "problem.graphslam");
  EXPECT_EQ((*store)->files()[1].path, "scans/SCANS.json");
}

TEST_F(ChunkStoreIntegrity, DeletedProblemLineIsCorruptionNamingTheFile) {
  std::string text = Read(Problem());
  const size_t line = text.find("\nPOSE");  // the first POSE line after the header
  ASSERT_NE(line, std::string::npos);
  text.erase(line, text.find('\n', line + 1) - line);
  Write(Problem(), text);
  Status status = ReadAll();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(Problem().string()));
}

TEST_F(ChunkStoreIntegrity, ChangedProblemDigitIsCorruptionNamingTheFile) {
  std::string text = Read(Problem());
  const size_t line = text.rfind("\nFEATURE");
  ASSERT_NE(line, std::string::npos);
  const size_t digit = text.find_first_of("123456789", text.find(' ', line + 9));
  text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);  // same size
  Write(Problem(), text);
  Status status = ReadAll();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(Problem().string()));
  EXPECT_THAT(status.message(), HasSubstr("crc32c"));
}

TEST_F(ChunkStoreIntegrity, ManifestEditedDownToFewerChunksIsCorruption) {
  nlohmann::json manifest = nlohmann::json::parse(Read(Manifest()));
  ASSERT_GE(manifest["chunks"].size(), 2u);
  const nlohmann::json last = manifest["chunks"].back();
  manifest["chunks"].erase(manifest["chunks"].size() - 1);
  // Consistent by hand: counts and totals as for the shorter list.
  manifest["num_chunks"] = manifest["num_chunks"].get<int64_t>() - 1;
  for (const char* key : {"features", "observations", "bytes"})
    manifest[std::string("total_") + key] =
        manifest[std::string("total_") + key].get<int64_t>() - last[key].get<int64_t>();
  Write(Manifest(), manifest.dump(2));
  Status status = ReadAll();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(Manifest().string()));
  EXPECT_THAT(status.message(), HasSubstr("checksum"));
}

TEST_F(ChunkStoreIntegrity, ChangedManifestDigitIsCorruption) {
  std::string text = Read(Manifest());
  const size_t at = text.find("\"observations\": ");
  ASSERT_NE(at, std::string::npos);
  const size_t digit = at + std::string("\"observations\": ").size();
  text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);
  Write(Manifest(), text);
  Status status = ReadAll();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(Manifest().string()));
}

TEST_F(ChunkStoreIntegrity, RemovedManifestChecksumIsCorruption) {
  nlohmann::json manifest = nlohmann::json::parse(Read(Manifest()));
  manifest.erase("checksum");
  Write(Manifest(), manifest.dump(2));
  Status status = ReadAll();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr("checksum"));
}

TEST_F(ChunkStoreIntegrity, ChangedChunkByteIsCorruptionNamingTheChunk) {
  const fs::path chunk = dir_ / "chunks" / "000001.gsc";
  std::string bytes = Read(chunk);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x01);
  Write(chunk, bytes);
  Status status = ReadAll();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr("000001.gsc"));
}

TEST_F(ChunkStoreIntegrity, DeletedChunkFailsOnOpen) {
  fs::remove(dir_ / "chunks" / "000001.gsc");
  StatusOr<std::unique_ptr<DiskChunkSource>> store = DiskChunkSource::Open(dir_.string());
  ASSERT_FALSE(store.ok());
  EXPECT_TRUE(store.status().IsNotFound()) << store.status().ToString();
  EXPECT_THAT(store.status().message(), HasSubstr("000001.gsc"));
}

TEST_F(ChunkStoreIntegrity, ChangedOrDeletedScansFileIsDetected) {
  const fs::path scans = dir_ / "scans" / "SCANS.json";
  std::string text = Read(scans);
  text[2] = 'F';  // same size
  Write(scans, text);
  Status status = ReadAll();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(scans.string()));
  fs::remove(scans);
  status = ReadAll();
  EXPECT_TRUE(status.IsNotFound()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(scans.string()));
}

TEST_F(ChunkStoreIntegrity, VersionOneStoreIsStillRead) {
  nlohmann::json manifest = nlohmann::json::parse(Read(Manifest()));
  manifest.erase("checksum");
  manifest.erase("files");
  manifest.erase("input");
  manifest["version"] = 1;
  for (nlohmann::json& entry : manifest["chunks"]) entry.erase("crc32c");
  Write(Manifest(), manifest.dump(2));
  Status status = ReadAll();
  EXPECT_TRUE(status.ok()) << status.ToString();
  StatusOr<std::unique_ptr<DiskChunkSource>> store = DiskChunkSource::Open(dir_.string());
  ASSERT_TRUE(store.ok());
  EXPECT_EQ((*store)->version(), 1);
  EXPECT_LT((*store)->input().bytes, 0);
}

TEST_F(ChunkStoreIntegrity, VersionEditedDownToOneIsCorruption) {
  std::string text = Read(Manifest());
  const size_t at = text.find("\"version\": 2");
  ASSERT_NE(at, std::string::npos);
  text[at + 11] = '1';
  Write(Manifest(), text);
  Status status = DiskChunkSource::Open(dir_.string()).status();
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(Manifest().string()));
}

TEST_F(ChunkStoreIntegrity, NewerVersionIsNotSupported) {
  nlohmann::json manifest = nlohmann::json::parse(Read(Manifest()));
  manifest["version"] = kChunkStoreVersion + 1;
  Write(Manifest(), manifest.dump(2));
  EXPECT_TRUE(DiskChunkSource::Open(dir_.string()).status().IsNotSupported());
}

// Two shard writers (as two MPI ranks of `mpirun graphslam ingest`) into
// one folder write the one-call writer's chunk files; the manifest lists the
// shards and the reader returns them.
TEST_F(ChunkStoreIntegrity, ShardsOfTwoWritersMakeTheSameStore) {
  const core::Problem2d problem = StoreProblem();
  partition::InMemoryChunkSource chunks(problem, StoreChunking());
  ASSERT_GE(chunks.NumChunks(), 2);
  const int64_t half = chunks.NumChunks() / 2;
  const fs::path sharded = dir_.string() + "_sharded";
  fs::remove_all(sharded);
  ASSERT_TRUE(ClaimStoreDirectory(Env::Default(), sharded.string()).ok());
  Write(sharded / "scans" / "SCANS.json", "{\"format\": \"graphslam-scan-store\"}\n");
  ChunkStoreWriteOptions write;
  write.source = "input.graphslam";
  write.input = FileChecksum{1234, 0xdeadbeef};
  ChunkStoreWriter rank0(Env::Default(), sharded.string(), write);
  ChunkStoreWriter rank1(Env::Default(), sharded.string(), write);
  ASSERT_TRUE(rank0.Uncommit().ok());
  ASSERT_TRUE(rank0.WriteProblem(problem).ok());
  ASSERT_TRUE(rank1.WriteChunkShard(chunks, half, chunks.NumChunks()).ok());
  ASSERT_TRUE(rank0.WriteChunkShard(chunks, 0, half).ok());
  std::vector<ChunkStoreEntry> entries = rank0.entries();
  entries.insert(entries.end(), rank1.entries().begin(), rank1.entries().end());
  rank0.SetEntries(entries, {{0, 0, half}, {1, half, chunks.NumChunks() - half}});
  ASSERT_TRUE(rank0.Commit().ok());

  const nlohmann::json one = nlohmann::json::parse(Read(Manifest()));
  const nlohmann::json two = nlohmann::json::parse(Read(sharded / kChunkStoreManifestName));
  EXPECT_EQ(two["chunks"], one["chunks"]);
  EXPECT_EQ(two["files"], one["files"]);
  StatusOr<std::unique_ptr<DiskChunkSource>> store = DiskChunkSource::Open(sharded.string());
  ASSERT_TRUE(store.ok()) << store.status().ToString();
  ASSERT_EQ((*store)->shards().size(), 2u);
  EXPECT_EQ((*store)->shards()[1].rank, 1);
  EXPECT_EQ((*store)->shards()[1].first_chunk, half);
  EXPECT_EQ((*store)->shards()[1].chunks, chunks.NumChunks() - half);
  fs::remove_all(sharded);
}

// Shards that do not cover the chunks in rank order are Corruption naming
// the field, even with the manifest's checksum made right.
TEST_F(ChunkStoreIntegrity, ShardsNotCoveringTheChunksAreCorruption) {
  nlohmann::json manifest = nlohmann::json::parse(Read(Manifest()));
  const int64_t chunks = manifest["num_chunks"].get<int64_t>();
  ASSERT_GE(chunks, 2);
  manifest.erase(kJsonChecksumKey);
  manifest["shards"] = {{{"rank", 0}, {"first_chunk", 0}, {"chunks", 1}},
                        {{"rank", 1}, {"first_chunk", 2}, {"chunks", chunks - 2}}};
  SealJson(&manifest);
  Write(Manifest(), manifest.dump(2));
  StatusOr<std::unique_ptr<DiskChunkSource>> store = DiskChunkSource::Open(dir_.string());
  ASSERT_TRUE(store.status().IsCorruption()) << store.status().ToString();
  EXPECT_THAT(store.status().message(), HasSubstr("shards[1]"));

  manifest.erase(kJsonChecksumKey);
  manifest["shards"] = {{{"rank", 0}, {"first_chunk", 0}, {"chunks", chunks - 1}}};
  SealJson(&manifest);
  Write(Manifest(), manifest.dump(2));
  store = DiskChunkSource::Open(dir_.string());
  ASSERT_TRUE(store.status().IsCorruption()) << store.status().ToString();
  EXPECT_THAT(store.status().message(), HasSubstr("\"shards\" cover"));
}

TEST(FileChecksum, InputIdentityOfAFolderCoversNamesAndContents) {
  const fs::path dir = fs::temp_directory_path() / ("file_checksum_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  Write(dir / "a.dat", "hello");
  Write(dir / "sub" / "b.dat", "world");
  StatusOr<FileChecksum> first = IdentifyInput(dir.string());
  ASSERT_TRUE(first.ok());
  EXPECT_EQ(first->bytes, 10);
  Write(dir / "sub" / "b.dat", "worle");  // same size, other contents
  StatusOr<FileChecksum> changed = IdentifyInput(dir.string());
  ASSERT_TRUE(changed.ok());
  EXPECT_NE(first->crc32c, changed->crc32c);
  Write(dir / "sub" / "b.dat", "world");
  fs::rename(dir / "a.dat", dir / "c.dat");  // same bytes, other name
  StatusOr<FileChecksum> renamed = IdentifyInput(dir.string());
  ASSERT_TRUE(renamed.ok());
  EXPECT_NE(first->crc32c, renamed->crc32c);
  StatusOr<FileChecksum> file = IdentifyInput((dir / "sub" / "b.dat").string());
  ASSERT_TRUE(file.ok());
  EXPECT_EQ(*file, (FileChecksum{5, crc32c::Value("world")}));
  EXPECT_TRUE(IdentifyInput((dir / "missing").string()).status().IsNotFound());
  fs::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::storage
