// RemoveAbandonedTemporaries removes exactly the temporaries of one output
// whose writer is gone: its pid does not exist and nobody locks the file.
#include "storage/abandoned_temporaries.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/file.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "storage/atomic_file.h"

namespace graphslam::storage {
namespace {

namespace fs = std::filesystem;

// The pid of a child that has exited and been reaped: no process has it.
long long DeadPid() {
  const pid_t pid = ::fork();
  if (pid == 0) ::_exit(0);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return pid;
}

class AbandonedTemporariesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("graphslam_abandoned_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path Touch(const std::string& name) const {
    std::ofstream(dir_ / name) << "partial";
    return dir_ / name;
  }
  fs::path dir_;
};

TEST_F(AbandonedTemporariesTest, RemovesOnlyTheDeadWritersTemporariesOfThisOutput) {
  const std::string dead = std::to_string(DeadPid());
  const std::string alive = std::to_string(::getpid());
  Touch("out.g2o.tmp-" + dead);                  // ours, writer gone
  Touch("out.g2o.state.3.bin.tmp-" + dead);      // a companion's, writer gone
  Touch("out.g2o.tmp-" + alive);                 // a live writer's
  Touch("other.g2o.tmp-" + dead);                // another output's
  Touch("out.g2o.tmp-12ab");                     // not a temporary name
  Touch("out.g2o2.tmp-" + dead);                 // another file's name prefix
  Touch("out.g2o");
  fs::create_symlink(dir_ / "out.g2o", dir_ / ("out.g2o.link.tmp-" + dead));

  StatusOr<int64_t> removed = RemoveAbandonedTemporaries((dir_ / "out.g2o").string());
  ASSERT_TRUE(removed.ok()) << removed.status().ToString();
  EXPECT_EQ(*removed, 2);
  EXPECT_FALSE(fs::exists(dir_ / ("out.g2o.tmp-" + dead)));
  EXPECT_FALSE(fs::exists(dir_ / ("out.g2o.state.3.bin.tmp-" + dead)));
  EXPECT_TRUE(fs::exists(dir_ / ("out.g2o.tmp-" + alive)));
  EXPECT_TRUE(fs::exists(dir_ / ("other.g2o.tmp-" + dead)));
  EXPECT_TRUE(fs::exists(dir_ / "out.g2o.tmp-12ab"));
  EXPECT_TRUE(fs::exists(dir_ / ("out.g2o2.tmp-" + dead)));
  EXPECT_TRUE(fs::exists(dir_ / "out.g2o"));
  EXPECT_TRUE(fs::is_symlink(dir_ / ("out.g2o.link.tmp-" + dead)));
}

// A writer whose pid this machine cannot see (a shared folder) holds a lock
// on its temporary: that file stays.
TEST_F(AbandonedTemporariesTest, KeepsALockedTemporary) {
  const fs::path temporary = Touch("report.json.tmp-" + std::to_string(DeadPid()));
  const int fd = ::open(temporary.c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(::flock(fd, LOCK_EX), 0);
  StatusOr<int64_t> removed = RemoveAbandonedTemporaries((dir_ / "report.json").string());
  ASSERT_TRUE(removed.ok());
  EXPECT_EQ(*removed, 0);
  EXPECT_TRUE(fs::exists(temporary));
  ::close(fd);
  removed = RemoveAbandonedTemporaries((dir_ / "report.json").string());
  ASSERT_TRUE(removed.ok());
  EXPECT_EQ(*removed, 1);
  EXPECT_FALSE(fs::exists(temporary));
}

// WriteFileAtomically locks its temporary while writing: a cleaner running
// meanwhile (same pid rule aside) finds it locked.
TEST_F(AbandonedTemporariesTest, AtomicWriterLocksItsTemporaryWhileWriting) {
  const std::string target = (dir_ / "graph.g2o").string();
  bool locked_while_writing = false;
  ASSERT_TRUE(WriteFileAtomically(Env::Default(), target, [&](WritableFile* file) -> Status {
                const int fd = ::open(TemporaryFileName(target).c_str(), O_RDONLY);
                locked_while_writing = fd >= 0 && ::flock(fd, LOCK_EX | LOCK_NB) != 0;
                if (fd >= 0) ::close(fd);
                return file->Append("x\n");
              }).ok());
  EXPECT_TRUE(locked_while_writing);
  EXPECT_FALSE(fs::exists(TemporaryFileName(target)));
}

TEST_F(AbandonedTemporariesTest, MissingFolderOrStandardOutputIsNothingToDo) {
  EXPECT_EQ(*RemoveAbandonedTemporaries("-"), 0);
  EXPECT_EQ(*RemoveAbandonedTemporaries((dir_ / "nodir" / "x.g2o").string()), 0);
}

}  // namespace
}  // namespace graphslam::storage
