// Tests of storage/store_directory.h: a folder that is not ours is refused
// before anything is written or deleted (issue 22, defect 4); an empty or
// missing folder is claimed; a store of ours (marker, or a manifest of our
// format) is ours; only "NAME.tmp-<digits>" files count as stale temporaries.
#include "storage/store_directory.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "core/initialization.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/chunk_store.h"
#include "tests/testing/random_problem.h"

namespace graphslam::storage {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

class StoreDirectoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() / ("store_directory_test_" + std::to_string(::getpid()) +
                                         "_" + ::testing::UnitTest::GetInstance()
                                                   ->current_test_info()
                                                   ->name());
    fs::remove_all(root_);
    fs::create_directories(root_);
  }
  void TearDown() override { fs::remove_all(root_); }

  static void Write(const fs::path& path, const std::string& text) {
    fs::create_directories(path.parent_path());
    std::ofstream(path) << text;
  }
  static std::string Read(const fs::path& path) {
    std::ifstream in(path);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }

  fs::path root_;
};

Status WriteSmallStore(const std::string& dir) {
  testing::RandomProblemOptions options;
  options.num_poses = 30;
  options.num_features = 10;
  core::Problem2d problem = testing::MakeRandomProblem(options).problem;
  GS_RETURN_IF_ERROR(core::InitializeProblem(&problem));
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = 20;
  partition::InMemoryChunkSource chunks(problem, chunking);
  return WriteChunkStore(Env::Default(), dir, problem, chunks, ChunkStoreWriteOptions());
}

// The case: a user folder with scans/ and work/ subfolders and a
// temporary-looking file is never emptied by a store writer.
TEST_F(StoreDirectoryTest, ForeignFolderIsRefusedAndNothingIsDeleted) {
  const fs::path dir = root_ / "photos";
  Write(dir / "scans" / "holiday.jpg", "scan");
  Write(dir / "work" / "thesis.tex", "work");
  Write(dir / "chunks" / "notes.txt", "chunks");
  Write(dir / "draft.txt.tmp-42", "draft");
  Status check = CheckStoreDirectory(dir.string());
  ASSERT_TRUE(check.IsInvalidArgument()) << check.ToString();
  EXPECT_THAT(check.message(), HasSubstr(dir.string()));
  EXPECT_THAT(check.message(), HasSubstr("not a graphslam chunk store"));

  Status write = WriteSmallStore(dir.string());
  EXPECT_TRUE(write.IsInvalidArgument()) << write.ToString();
  StatusOr<DirectoryLock> lock = OpenStoreForWriting(Env::Default(), dir.string());
  EXPECT_FALSE(lock.ok());
  EXPECT_EQ(Read(dir / "scans" / "holiday.jpg"), "scan");
  EXPECT_EQ(Read(dir / "work" / "thesis.tex"), "work");
  EXPECT_EQ(Read(dir / "chunks" / "notes.txt"), "chunks");
  EXPECT_EQ(Read(dir / "draft.txt.tmp-42"), "draft");
  EXPECT_FALSE(fs::exists(dir / kStoreMarkerName));
  EXPECT_FALSE(fs::exists(dir / kDirectoryLockName));
  EXPECT_FALSE(fs::exists(dir / kChunkStoreManifestName));
}

TEST_F(StoreDirectoryTest, AFileIsNotAStoreFolder) {
  Write(root_ / "file", "x");
  EXPECT_TRUE(CheckStoreDirectory((root_ / "file").string()).IsInvalidArgument());
}

TEST_F(StoreDirectoryTest, MissingAndEmptyFoldersAreClaimed) {
  const fs::path missing = root_ / "new" / "store";
  StatusOr<DirectoryLock> lock = OpenStoreForWriting(Env::Default(), missing.string());
  ASSERT_TRUE(lock.ok()) << lock.status().ToString();
  EXPECT_TRUE(fs::exists(missing / kStoreMarkerName));
  const fs::path empty = root_ / "empty";
  fs::create_directories(empty);
  EXPECT_TRUE(ClaimStoreDirectory(Env::Default(), empty.string()).ok());
  EXPECT_TRUE(fs::exists(empty / kStoreMarkerName));
  // Ours from now on, whatever is added to it.
  Write(empty / "work" / "x", "x");
  EXPECT_TRUE(CheckStoreDirectory(empty.string()).ok());
}

TEST_F(StoreDirectoryTest, AStoreWithoutMarkerIsOursByItsManifest) {
  const fs::path dir = root_ / "store";
  ASSERT_TRUE(WriteSmallStore(dir.string()).ok());
  fs::remove(dir / kStoreMarkerName);  // as written before markers existed
  EXPECT_TRUE(CheckStoreDirectory(dir.string()).ok());
  // A manifest of another format does not make a folder ours.
  const fs::path other = root_ / "other";
  Write(other / kChunkStoreManifestName, "{\"format\": \"someone-else\"}");
  EXPECT_TRUE(CheckStoreDirectory(other.string()).IsInvalidArgument());
}

TEST_F(StoreDirectoryTest, SecondWriterFailsWhileTheFirstHoldsTheStore) {
  const fs::path dir = root_ / "store";
  StatusOr<DirectoryLock> first = OpenStoreForWriting(Env::Default(), dir.string());
  ASSERT_TRUE(first.ok());
  StatusOr<DirectoryLock> second = OpenStoreForWriting(Env::Default(), dir.string());
  ASSERT_FALSE(second.ok());
  EXPECT_THAT(second.status().message(), HasSubstr("pid " + std::to_string(::getpid())));
}

TEST_F(StoreDirectoryTest, OnlyTemporaryNamesAreRemoved) {
  EXPECT_TRUE(IsTemporaryFileName("checkpoint.json.tmp-1234"));
  EXPECT_FALSE(IsTemporaryFileName(".tmp-1234"));
  EXPECT_FALSE(IsTemporaryFileName("a.tmp-"));
  EXPECT_FALSE(IsTemporaryFileName("a.tmp-12x"));
  EXPECT_FALSE(IsTemporaryFileName("a.tmp"));
  const fs::path dir = root_ / "store";
  Write(dir / "checkpoint.json.tmp-77", "t");
  Write(dir / "work" / "pass1.bin.tmp-78", "t");
  Write(dir / "keep.tmp-x", "k");
  Write(dir / "keep.txt", "k");
  ASSERT_TRUE(RemoveStaleTemporaries(Env::Default(), dir.string(), /*recursive=*/false).ok());
  EXPECT_FALSE(fs::exists(dir / "checkpoint.json.tmp-77"));
  EXPECT_TRUE(fs::exists(dir / "work" / "pass1.bin.tmp-78"));
  ASSERT_TRUE(RemoveStaleTemporaries(Env::Default(), dir.string(), /*recursive=*/true).ok());
  EXPECT_FALSE(fs::exists(dir / "work" / "pass1.bin.tmp-78"));
  EXPECT_TRUE(fs::exists(dir / "keep.tmp-x"));
  EXPECT_TRUE(fs::exists(dir / "keep.txt"));
}

}  // namespace
}  // namespace graphslam::storage
