#include "storage/env.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace graphslam::storage {
namespace {

using Operation = FaultInjectionEnv::Operation;

std::string TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("graphslam_env_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

TEST(PosixEnv, WritesAppendsLargerThanTheBuffer) {
  const std::string dir = TempDir("large");
  Env* env = Env::Default();
  auto file = env->NewWritableFile(dir + "/a.txt");
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  const std::string big(200 * 1024, 'x');
  ASSERT_TRUE((*file)->Append("head").ok());
  ASSERT_TRUE((*file)->Append(big).ok());
  ASSERT_TRUE((*file)->Sync().ok());
  ASSERT_TRUE((*file)->Close().ok());
  EXPECT_EQ(Slurp(dir + "/a.txt"), "head" + big);
  EXPECT_TRUE((*file)->Append("late").IsIOError());
  std::filesystem::remove_all(dir);
}

TEST(PosixEnv, RenameRemoveAndExists) {
  const std::string dir = TempDir("rename");
  Env* env = Env::Default();
  {
    auto file = env->NewWritableFile(dir + "/a");
    ASSERT_TRUE(file.ok());
    ASSERT_TRUE((*file)->Close().ok());
  }
  EXPECT_TRUE(env->FileExists(dir + "/a"));
  ASSERT_TRUE(env->Rename(dir + "/a", dir + "/b").ok());
  EXPECT_FALSE(env->FileExists(dir + "/a"));
  EXPECT_TRUE(env->FileExists(dir + "/b"));
  EXPECT_TRUE(env->SyncDirectory(dir).ok());
  ASSERT_TRUE(env->RemoveFile(dir + "/b").ok());
  const Status missing = env->RemoveFile(dir + "/b");
  EXPECT_TRUE(missing.IsIOError());
  EXPECT_NE(missing.message().find("/b: unlink: No such file"), std::string::npos)
      << missing.ToString();
  EXPECT_TRUE(env->NewWritableFile(dir + "/no/such/dir/file").status().IsIOError());
  std::filesystem::remove_all(dir);
}

TEST(PosixEnv, DefaultIsOneObject) { EXPECT_EQ(Env::Default(), Env::Default()); }

TEST(FaultInjectionEnv, FailsExactlyTheNthCall) {
  const std::string dir = TempDir("nth");
  FaultInjectionEnv env(Env::Default());
  env.FailAt(Operation::kAppend, 2);
  auto file = env.NewWritableFile(dir + "/f");
  ASSERT_TRUE(file.ok());
  EXPECT_TRUE((*file)->Append("one").ok());
  const Status second = (*file)->Append("two");
  EXPECT_TRUE(second.IsIOError());
  EXPECT_EQ(second.message(), dir + "/f: append: injected fault (call 2)");
  EXPECT_TRUE((*file)->Append("three").ok());
  ASSERT_TRUE((*file)->Close().ok());
  EXPECT_EQ(Slurp(dir + "/f"), "onethree");  // the failed append wrote nothing
  EXPECT_EQ(env.Count(Operation::kAppend), 3);
  EXPECT_EQ(env.Count(Operation::kClose), 1);
  std::filesystem::remove_all(dir);
}

TEST(FaultInjectionEnv, FailAlwaysAndReset) {
  const std::string dir = TempDir("always");
  FaultInjectionEnv env(Env::Default());
  env.FailAlways(Operation::kNewWritableFile);
  EXPECT_TRUE(env.NewWritableFile(dir + "/f").status().IsIOError());
  EXPECT_TRUE(env.NewWritableFile(dir + "/f").status().IsIOError());
  EXPECT_FALSE(env.FileExists(dir + "/f"));
  env.Reset();
  EXPECT_EQ(env.Count(Operation::kNewWritableFile), 0);
  auto file = env.NewWritableFile(dir + "/f");
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE((*file)->Close().ok());
  env.FailAt(Operation::kRename, 1);
  EXPECT_TRUE(env.Rename(dir + "/f", dir + "/g").IsIOError());
  EXPECT_TRUE(env.FileExists(dir + "/f"));  // a failed rename renames nothing
  EXPECT_TRUE(env.Rename(dir + "/f", dir + "/g").ok());
  EXPECT_TRUE(env.FileExists(dir + "/g"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::storage
