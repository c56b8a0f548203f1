// Tests of storage/directory_lock.h: one exclusive holder or many shared
// ones; a conflicting Acquire fails at once with IOError naming the folder
// and the holder's pid. Two DirectoryLocks in one process conflict like two
// processes (flock on separate open file descriptions), so these tests need
// no child process and no timing.
#include "storage/directory_lock.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace graphslam::storage {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

class DirectoryLockTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = (fs::temp_directory_path() / ("directory_lock_test_" + std::to_string(::getpid()) +
                                         "_" + ::testing::UnitTest::GetInstance()
                                                   ->current_test_info()
                                                   ->name()))
               .string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string dir_;
};

const std::string kPid = "pid " + std::to_string(::getpid());

TEST_F(DirectoryLockTest, SecondExclusiveFailsNamingTheHoldersPid) {
  StatusOr<DirectoryLock> first = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive);
  ASSERT_TRUE(first.ok()) << first.status().ToString();
  EXPECT_TRUE(first->held());
  StatusOr<DirectoryLock> second = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive);
  ASSERT_FALSE(second.ok());
  EXPECT_TRUE(second.status().IsIOError()) << second.status().ToString();
  EXPECT_THAT(second.status().message(), HasSubstr(dir_));
  EXPECT_THAT(second.status().message(), HasSubstr(kPid));
  EXPECT_THAT(second.status().message(), HasSubstr("locked by another graphslam process"));
}

TEST_F(DirectoryLockTest, ReadersShareButExcludeAWriter) {
  StatusOr<DirectoryLock> a = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kShared);
  StatusOr<DirectoryLock> b = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kShared);
  ASSERT_TRUE(a.ok()) << a.status().ToString();
  ASSERT_TRUE(b.ok()) << b.status().ToString();
  StatusOr<DirectoryLock> writer = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive);
  ASSERT_FALSE(writer.ok());
  EXPECT_TRUE(writer.status().IsIOError());
  a->Release();
  b->Release();
  EXPECT_TRUE(DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive).ok());
}

TEST_F(DirectoryLockTest, AWriterExcludesReadersAndNamesItsPid) {
  StatusOr<DirectoryLock> writer = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive);
  ASSERT_TRUE(writer.ok());
  std::ifstream in(fs::path(dir_) / kDirectoryLockName);
  std::string content;
  std::getline(in, content);
  EXPECT_EQ(content, std::to_string(::getpid()));
  StatusOr<DirectoryLock> reader = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kShared);
  ASSERT_FALSE(reader.ok());
  EXPECT_THAT(reader.status().message(), HasSubstr(kPid));
}

TEST_F(DirectoryLockTest, ReleaseAndDestructionUnlock) {
  {
    StatusOr<DirectoryLock> scoped = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive);
    ASSERT_TRUE(scoped.ok());
  }
  StatusOr<DirectoryLock> again = DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive);
  ASSERT_TRUE(again.ok()) << again.status().ToString();
  DirectoryLock moved = std::move(again).value();
  EXPECT_TRUE(moved.held());
  EXPECT_FALSE(DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive).ok());
  moved.Release();
  EXPECT_FALSE(moved.held());
  EXPECT_TRUE(DirectoryLock::Acquire(dir_, DirectoryLock::Mode::kExclusive).ok());
}

TEST_F(DirectoryLockTest, MissingFolderIsNotFound) {
  StatusOr<DirectoryLock> lock =
      DirectoryLock::Acquire(dir_ + "/missing", DirectoryLock::Mode::kExclusive);
  ASSERT_FALSE(lock.ok());
  EXPECT_TRUE(lock.status().IsNotFound()) << lock.status().ToString();
}

}  // namespace
}  // namespace graphslam::storage
