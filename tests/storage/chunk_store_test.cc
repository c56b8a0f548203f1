// Tests of the chunk store (storage/chunk_store.h, docs/formats/chunk_store.md):
// bit-exact round trips of every chunk, store-vs-in-memory solve equality
// (final chi2 within 1e-9 relative) on a random problem and on Victoria Park,
// and rejection of incomplete or damaged stores.
#include "storage/chunk_store.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>

#include "core/graphslam_solver.h"
#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/env.h"
#include "storage/g2o_reader.h"
#include "tests/testing/datasets.h"
#include "tests/testing/random_problem.h"

namespace graphslam::storage {
namespace {

using ::testing::HasSubstr;
using Operation = FaultInjectionEnv::Operation;

class ScratchDir {
 public:
  explicit ScratchDir(const std::string& name)
      : path_((std::filesystem::temp_directory_path() /
               ("chunk_store_test_" + std::to_string(::getpid()) + "_" + name))
                  .string()) {
    std::filesystem::remove_all(path_);
  }
  ~ScratchDir() {
    std::error_code error;
    std::filesystem::remove_all(path_, error);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

core::Problem2d InitializedRandomProblem(uint32_t seed) {
  testing::RandomProblemOptions options;
  options.num_poses = 60;
  options.num_features = 40;
  options.seed = seed;
  core::Problem2d problem = testing::MakeRandomProblem(options).problem;
  EXPECT_TRUE(core::InitializeProblem(&problem).ok());
  return problem;
}

bool SameBits(const void* a, const void* b, size_t bytes) { return std::memcmp(a, b, bytes) == 0; }

void ExpectSameChunk(const core::ObservationChunk& expected, const core::ObservationChunk& actual) {
  EXPECT_EQ(expected.index, actual.index);
  EXPECT_EQ(expected.features, actual.features);
  EXPECT_EQ(expected.feature_begin, actual.feature_begin);
  ASSERT_EQ(expected.observations.size(), actual.observations.size());
  for (size_t k = 0; k < expected.observations.size(); ++k) {
    const core::Observation& e = expected.observations[k];
    const core::Observation& a = actual.observations[k];
    EXPECT_EQ(e.pose, a.pose) << "observation " << k;
    EXPECT_EQ(e.feature, a.feature) << "observation " << k;
    EXPECT_EQ(e.kind, a.kind) << "observation " << k;
    EXPECT_EQ(e.line, a.line) << "observation " << k;
    EXPECT_TRUE(SameBits(e.z.data(), a.z.data(), sizeof(double) * 2))
        << "observation " << k << ": z " << e.z.transpose() << " vs " << a.z.transpose();
    EXPECT_TRUE(SameBits(e.information.data(), a.information.data(), sizeof(double) * 4))
        << "observation " << k << ": information differs";
  }
}

Status WriteStore(const std::string& dir, const core::Problem2d& problem, int64_t chunk_size,
                  bool compress, Env* env = Env::Default()) {
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = chunk_size;
  partition::InMemoryChunkSource chunks(problem, chunking);
  ChunkStoreWriteOptions options;
  options.source = "random";
  if (compress) options.chunk.compression = ChunkCompression::kZstd;
  return WriteChunkStore(env, dir, problem, chunks, options);
}

TEST(ChunkStore, EveryChunkRoundTripsBitForBit) {
  const core::Problem2d problem = InitializedRandomProblem(7);
  for (bool compress : {false, true}) {
    for (int64_t chunk_size : {1, 17, 100000}) {
      SCOPED_TRACE(::testing::Message() << "compress " << compress << " chunk " << chunk_size);
      ScratchDir dir("roundtrip");
      ASSERT_TRUE(WriteStore(dir.path(), problem, chunk_size, compress).ok());
      EXPECT_TRUE(IsChunkStore(dir.path()));
      partition::ChunkingOptions chunking;
      chunking.max_observations_per_chunk = chunk_size;
      partition::InMemoryChunkSource memory(problem, chunking);
      StatusOr<std::unique_ptr<DiskChunkSource>> disk = DiskChunkSource::Open(dir.path());
      ASSERT_TRUE(disk.ok()) << disk.status().ToString();
      ASSERT_EQ((*disk)->NumChunks(), memory.NumChunks());
      EXPECT_EQ((*disk)->total_observations(), static_cast<int64_t>(problem.observations.size()));
      EXPECT_EQ((*disk)->source(), "random");
      for (int64_t k = 0; k < memory.NumChunks(); ++k) {
        core::ObservationChunk expected, actual;
        ASSERT_TRUE(memory.Load(k, &expected).ok());
        Status status = (*disk)->Load(k, &actual);
        ASSERT_TRUE(status.ok()) << status.ToString();
        ExpectSameChunk(expected, actual);
      }
      StatusOr<core::Problem2d> read = ReadChunkStoreProblem(dir.path());
      ASSERT_TRUE(read.ok()) << read.status().ToString();
      EXPECT_TRUE(read->observations.empty());
      ASSERT_EQ(read->num_poses(), problem.num_poses());
      ASSERT_EQ(read->num_features(), problem.num_features());
      for (int32_t i = 0; i < problem.num_poses(); ++i)
        EXPECT_TRUE(SameBits(read->poses[i].data(), problem.poses[i].data(), sizeof(double) * 3))
            << "pose " << i;
      for (int32_t j = 0; j < problem.num_features(); ++j)
        EXPECT_TRUE(
            SameBits(read->features[j].data(), problem.features[j].data(), sizeof(double) * 2))
            << "feature " << j;
      EXPECT_EQ(read->relative_poses.size(), problem.relative_poses.size());
    }
  }
}

// Solves `problem` (initialized) in memory and from a store made of it, both
// with at most 20 iterations; the final chi2 must agree within 1e-9 relative.
void ExpectStoreSolveEqualsInMemory(const core::Problem2d& problem, int64_t chunk_size,
                                    const std::string& name) {
  core::SolverOptions options;
  options.max_iterations = 20;
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = chunk_size;

  core::Problem2d in_memory = problem;
  partition::InMemoryChunkSource memory_chunks(in_memory, chunking);
  core::SolverSummary memory_summary;
  ASSERT_TRUE(core::SolveGraphSlam(options, memory_chunks, &in_memory, &memory_summary).ok());

  ScratchDir dir(name);
  ASSERT_TRUE(WriteStore(dir.path(), problem, chunk_size, true).ok());
  StatusOr<core::Problem2d> stored = ReadChunkStoreProblem(dir.path());
  ASSERT_TRUE(stored.ok()) << stored.status().ToString();
  ASSERT_TRUE(core::InitializeProblem(&*stored).ok());
  StatusOr<std::unique_ptr<DiskChunkSource>> disk = DiskChunkSource::Open(dir.path());
  ASSERT_TRUE(disk.ok()) << disk.status().ToString();
  core::SolverSummary disk_summary;
  Status status = core::SolveGraphSlam(options, **disk, &*stored, &disk_summary);
  ASSERT_TRUE(status.ok()) << status.ToString();

  EXPECT_EQ(disk_summary.iterations, memory_summary.iterations);
  EXPECT_LE(std::abs(disk_summary.final_chi2 - memory_summary.final_chi2),
            1e-9 * std::abs(memory_summary.final_chi2))
      << "store " << disk_summary.final_chi2 << " vs in-memory " << memory_summary.final_chi2;
}

TEST(ChunkStore, SolveFromStoreEqualsInMemorySolveOnRandomProblem) {
  for (uint32_t seed : {1u, 2u, 3u}) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    ExpectStoreSolveEqualsInMemory(InitializedRandomProblem(seed), 50, "random_solve");
  }
}

TEST(ChunkStore, SolveFromStoreEqualsInMemorySolveOnVictoriaPark) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  StatusOr<core::Problem2d> read =
      ReadG2o(testing::DatasetPath("victoria_park/victoriaPark-full.g2o"));
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  core::Problem2d problem = std::move(read).value();
  ASSERT_TRUE(core::InitializeProblem(&problem).ok());
  ExpectStoreSolveEqualsInMemory(problem, 256, "victoria_solve");
}

TEST(ChunkStore, StoreWithoutManifestIsRejected) {
  ScratchDir dir("no_manifest");
  ASSERT_TRUE(WriteStore(dir.path(), InitializedRandomProblem(3), 20, false).ok());
  std::filesystem::remove(std::filesystem::path(dir.path()) / kChunkStoreManifestName);
  EXPECT_FALSE(IsChunkStore(dir.path()));
  StatusOr<std::unique_ptr<DiskChunkSource>> disk = DiskChunkSource::Open(dir.path());
  ASSERT_FALSE(disk.ok());
  EXPECT_TRUE(disk.status().IsCorruption()) << disk.status().ToString();
  EXPECT_THAT(disk.status().message(), HasSubstr("incomplete chunk store"));
  EXPECT_THAT(disk.status().message(), HasSubstr("MANIFEST.json"));
  StatusOr<core::Problem2d> problem = ReadChunkStoreProblem(dir.path());
  ASSERT_FALSE(problem.ok());
  EXPECT_THAT(problem.status().message(), HasSubstr("incomplete chunk store"));
}

TEST(ChunkStore, FailedManifestRenameLeavesAnIncompleteStore) {
  ScratchDir dir("manifest_rename");
  const core::Problem2d problem = InitializedRandomProblem(4);
  ASSERT_TRUE(WriteStore(dir.path(), problem, 20, false).ok());  // an older complete store
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = 20;
  const int64_t num_chunks = partition::InMemoryChunkSource(problem, chunking).NumChunks();
  FaultInjectionEnv env(Env::Default());
  // Renames: problem.graphslam, every chunk, then MANIFEST.json.
  env.FailAt(Operation::kRename, static_cast<int>(num_chunks) + 2);
  Status status = WriteStore(dir.path(), problem, 20, false, &env);
  ASSERT_TRUE(status.IsIOError()) << status.ToString();
  EXPECT_FALSE(IsChunkStore(dir.path()));
  EXPECT_FALSE(DiskChunkSource::Open(dir.path()).ok());
}

TEST(ChunkStore, DeletedChunkFileIsNotFoundNamingIt) {
  ScratchDir dir("deleted_chunk");
  ASSERT_TRUE(WriteStore(dir.path(), InitializedRandomProblem(5), 20, false).ok());
  StatusOr<std::unique_ptr<DiskChunkSource>> disk = DiskChunkSource::Open(dir.path());
  ASSERT_TRUE(disk.ok()) << disk.status().ToString();
  ASSERT_GE((*disk)->NumChunks(), 2);
  std::filesystem::remove(std::filesystem::path(dir.path()) / "chunks" / "000001.gsc");
  core::ObservationChunk chunk;
  EXPECT_TRUE((*disk)->Load(0, &chunk).ok());
  Status status = (*disk)->Load(1, &chunk);
  EXPECT_TRUE(status.IsNotFound()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr("000001.gsc"));
}

TEST(ChunkStore, ChunkOfWrongSizeIsCorruptionNamingIt) {
  ScratchDir dir("truncated_chunk");
  ASSERT_TRUE(WriteStore(dir.path(), InitializedRandomProblem(6), 20, false).ok());
  StatusOr<std::unique_ptr<DiskChunkSource>> disk = DiskChunkSource::Open(dir.path());
  ASSERT_TRUE(disk.ok()) << disk.status().ToString();
  const std::filesystem::path file = std::filesystem::path(dir.path()) / "chunks" / "000000.gsc";
  std::filesystem::resize_file(file, std::filesystem::file_size(file) - 3);
  core::ObservationChunk chunk;
  Status status = (*disk)->Load(0, &chunk);
  EXPECT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr("000000.gsc"));
}

}  // namespace
}  // namespace graphslam::storage
