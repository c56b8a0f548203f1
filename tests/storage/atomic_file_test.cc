#include "storage/atomic_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace graphslam::storage {
namespace {

using Operation = FaultInjectionEnv::Operation;

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = (std::filesystem::temp_directory_path() /
            ("graphslam_atomic_" +
             std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
             std::to_string(::getpid())))
               .string();
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
    path_ = dir_ + "/checkpoint.g2o";
    ASSERT_TRUE(WriteStringAtomically(Env::Default(), path_, "old contents\n").ok());
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  static std::string Slurp(const std::string& path) {
    std::ifstream in(path);
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
  }
  // Every file in the directory: only the checkpoint may remain.
  std::vector<std::string> Files() const {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(dir_)) {
      names.push_back(entry.path().filename().string());
    }
    return names;
  }
  // A writer that appends three pieces.
  static Status WriteNew(WritableFile* file) {
    GS_RETURN_IF_ERROR(file->Append("new "));
    GS_RETURN_IF_ERROR(file->Append("contents"));
    return file->Append("\n");
  }

  std::string dir_;
  std::string path_;
};

TEST_F(AtomicFileTest, ReplacesTheFileAndLeavesNoTemporary) {
  ASSERT_TRUE(WriteFileAtomically(Env::Default(), path_, WriteNew).ok());
  EXPECT_EQ(Slurp(path_), "new contents\n");
  EXPECT_EQ(Files(), std::vector<std::string>{"checkpoint.g2o"});
}

TEST_F(AtomicFileTest, CreatesAFileThatDidNotExist) {
  const std::string fresh = dir_ + "/fresh.txt";
  ASSERT_TRUE(WriteStringAtomically(Env::Default(), fresh, "x").ok());
  EXPECT_EQ(Slurp(fresh), "x");
}

TEST_F(AtomicFileTest, TemporaryNameCarriesThePid) {
  EXPECT_EQ(TemporaryFileName("a/b.g2o"), "a/b.g2o.tmp-" + std::to_string(::getpid()));
}

// Each injected fault must leave the old checkpoint intact and no temporary.
struct FaultCase {
  Operation operation;
  int nth;
  const char* what;
};

class AtomicFileFaultTest : public AtomicFileTest,
                            public ::testing::WithParamInterface<FaultCase> {};

TEST_P(AtomicFileFaultTest, FailureLeavesOldFileIntactAndNoTemporary) {
  FaultInjectionEnv env(Env::Default());
  env.FailAt(GetParam().operation, GetParam().nth);
  const Status status = WriteFileAtomically(&env, path_, WriteNew);
  ASSERT_TRUE(status.IsIOError()) << status.ToString();
  EXPECT_EQ(status.message().rfind("writing " + path_ + ": ", 0), 0u) << status.message();
  EXPECT_NE(status.message().find(std::string(GetParam().what) + ": injected fault"),
            std::string::npos)
      << status.message();
  EXPECT_EQ(Slurp(path_), "old contents\n");
  EXPECT_EQ(Files(), std::vector<std::string>{"checkpoint.g2o"});
  // The next write, without faults, succeeds.
  env.Reset();
  ASSERT_TRUE(WriteFileAtomically(&env, path_, WriteNew).ok());
  EXPECT_EQ(Slurp(path_), "new contents\n");
}

INSTANTIATE_TEST_SUITE_P(
    Faults, AtomicFileFaultTest,
    ::testing::Values(FaultCase{Operation::kNewWritableFile, 1, "open"},
                      FaultCase{Operation::kAppend, 1, "append"},
                      FaultCase{Operation::kAppend, 3, "append"},
                      FaultCase{Operation::kSync, 1, "sync"},
                      FaultCase{Operation::kClose, 1, "close"},
                      FaultCase{Operation::kRename, 1, "rename"}));

TEST_F(AtomicFileTest, WriterErrorIsReturnedAndNothingReplaced) {
  const Status status = WriteFileAtomically(Env::Default(), path_, [](WritableFile* file) {
    GS_RETURN_IF_ERROR(file->Append("partial"));
    return Status::InvalidArgument("pose 3 is not finite");
  });
  EXPECT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(status.message(), "writing " + path_ + ": pose 3 is not finite");
  EXPECT_EQ(Slurp(path_), "old contents\n");
  EXPECT_EQ(Files(), std::vector<std::string>{"checkpoint.g2o"});
}

TEST_F(AtomicFileTest, DirectorySyncFailureIsReportedAfterTheRename) {
  FaultInjectionEnv env(Env::Default());
  env.FailAt(Operation::kSyncDirectory, 1);
  const Status status = WriteFileAtomically(&env, path_, WriteNew);
  EXPECT_TRUE(status.IsIOError());
  EXPECT_NE(status.message().find("directory not synced"), std::string::npos);
  EXPECT_EQ(Slurp(path_), "new contents\n");  // renamed, durability unknown
}

TEST_F(AtomicFileTest, StaleTemporaryOfACrashedWriterDoesNotMatter) {
  // A process killed between write and rename leaves "<path>.tmp-<pid>".
  {
    std::ofstream stale(TemporaryFileName(path_));
    stale << "torn half-written checkp";
  }
  EXPECT_EQ(Slurp(path_), "old contents\n");  // the last good file still loads
  ASSERT_TRUE(WriteFileAtomically(Env::Default(), path_, WriteNew).ok());
  EXPECT_EQ(Slurp(path_), "new contents\n");
  EXPECT_EQ(Files(), std::vector<std::string>{"checkpoint.g2o"});
}

TEST_F(AtomicFileTest, MissingDirectoryIsAnIOError) {
  const Status status =
      WriteStringAtomically(Env::Default(), dir_ + "/missing/out.g2o", "x");
  EXPECT_TRUE(status.IsIOError()) << status.ToString();
}

}  // namespace
}  // namespace graphslam::storage
