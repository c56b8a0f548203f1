#include "storage/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

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

// Outputs that are not regular files are written in place, never replaced:
// as root, renaming over /dev/null replaced the machine's /dev/null.

bool IsSymlink(const std::string& path) {
  struct stat info;
  return ::lstat(path.c_str(), &info) == 0 && S_ISLNK(info.st_mode);
}

TEST_F(AtomicFileTest, SymlinkToACharacterDeviceIsWrittenThroughNotReplaced) {
  const std::string link = dir_ + "/null.g2o";
  std::filesystem::create_symlink("/dev/null", link);
  ASSERT_TRUE(WriteFileAtomically(Env::Default(), link, WriteNew).ok());
  EXPECT_TRUE(IsSymlink(link));
  EXPECT_EQ(std::filesystem::read_symlink(link), "/dev/null");
  EXPECT_TRUE(std::filesystem::is_character_file("/dev/null"));
  // Nothing was created beside it (no temporary, no stray copy).
  EXPECT_EQ(Files().size(), 2u);
}

TEST_F(AtomicFileTest, FifoIsWrittenInPlaceNotReplaced) {
  const std::string fifo = dir_ + "/pipe.g2o";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  // A reader like `cat pipe.g2o`: opening the FIFO for writing waits for it.
  std::thread reader([&] { received = Slurp(fifo); });
  const Status status = WriteFileAtomically(Env::Default(), fifo, WriteNew);
  reader.join();
  ASSERT_TRUE(status.ok()) << status.ToString();
  EXPECT_EQ(received, "new contents\n");
  struct stat info;
  ASSERT_EQ(::lstat(fifo.c_str(), &info), 0);
  EXPECT_TRUE(S_ISFIFO(info.st_mode));
}

TEST_F(AtomicFileTest, SymlinkToARegularFileReplacesTheTargetAndKeepsTheLink) {
  const std::string link = dir_ + "/latest.g2o";
  std::filesystem::create_symlink("checkpoint.g2o", link);
  ASSERT_TRUE(WriteFileAtomically(Env::Default(), link, WriteNew).ok());
  EXPECT_TRUE(IsSymlink(link));
  EXPECT_EQ(Slurp(path_), "new contents\n");
  EXPECT_EQ(Files().size(), 2u);
}

TEST_F(AtomicFileTest, DirectoryIsRefusedAndLeftAlone) {
  const std::string folder = dir_ + "/results";
  std::filesystem::create_directories(folder);
  std::ofstream(folder + "/mine.txt") << "user data\n";
  const Status status = WriteFileAtomically(Env::Default(), folder, WriteNew);
  ASSERT_TRUE(status.IsInvalidArgument()) << status.ToString();
  EXPECT_NE(status.ToString().find("is a directory"), std::string::npos) << status.ToString();
  EXPECT_EQ(Slurp(folder + "/mine.txt"), "user data\n");
}

TEST_F(AtomicFileTest, DashIsStandardOutput) {
  ::testing::internal::CaptureStdout();
  const Status status = WriteFileAtomically(Env::Default(), "-", WriteNew);
  const std::string printed = ::testing::internal::GetCapturedStdout();
  ASSERT_TRUE(status.ok()) << status.ToString();
  EXPECT_EQ(printed, "new contents\n");
  EXPECT_FALSE(std::filesystem::exists("-"));
}

}  // namespace
}  // namespace graphslam::storage
