#include "storage/env.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

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

TEST(PosixEnv, AppendsReadsSeeksAndSyncsScratchFiles) {
  const std::string dir = TempDir("scratch");
  const std::string path = dir + "/bucket.bin";
  Env* env = Env::Default();
  for (const std::string piece : {"first ", "second"}) {
    auto file = env->NewAppendableFile(path);  // created, then appended to
    ASSERT_TRUE(file.ok()) << file.status().ToString();
    ASSERT_TRUE((*file)->Append(piece).ok());
    ASSERT_TRUE((*file)->Close().ok());
  }
  ASSERT_TRUE(env->SyncFile(path).ok());
  auto whole = ReadFileToString(env, path);
  ASSERT_TRUE(whole.ok()) << whole.status().ToString();
  EXPECT_EQ(*whole, "first second");

  auto file = env->NewReadableFile(path);
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  auto size = (*file)->Size();
  ASSERT_TRUE(size.ok());
  EXPECT_EQ(*size, 12u);
  char buffer[16];
  ASSERT_TRUE((*file)->Seek(6).ok());
  auto got = (*file)->Read(sizeof(buffer), buffer);  // asks past the end: a short read
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(std::string(buffer, *got), "second");
  got = (*file)->Read(sizeof(buffer), buffer);
  ASSERT_TRUE(got.ok());
  EXPECT_EQ(*got, 0u);

  const auto missing = env->NewReadableFile(dir + "/missing.bin");
  EXPECT_TRUE(missing.status().IsNotFound()) << missing.status().ToString();
  EXPECT_NE(missing.status().message().find("missing.bin"), std::string::npos);
  EXPECT_TRUE(ReadFileToString(env, dir + "/missing.bin").status().IsNotFound());
  EXPECT_TRUE(env->SyncFile(dir + "/missing.bin").IsIOError());
}

TEST(FaultInjectionEnv, CountsAppendableOpensAndFileSyncs) {
  const std::string dir = TempDir("scratch_faults");
  FaultInjectionEnv env(Env::Default());
  env.FailAt(Operation::kNewWritableFile, 1);
  EXPECT_TRUE(env.NewAppendableFile(dir + "/a.bin").status().IsIOError());
  auto file = env.NewAppendableFile(dir + "/a.bin");
  ASSERT_TRUE(file.ok()) << file.status().ToString();
  env.FailAt(Operation::kAppend, 1);
  EXPECT_TRUE((*file)->Append("lost").IsIOError());
  ASSERT_TRUE((*file)->Append("kept").ok());
  ASSERT_TRUE((*file)->Close().ok());
  env.FailAt(Operation::kSync, 1);
  EXPECT_TRUE(env.SyncFile(dir + "/a.bin").IsIOError());
  EXPECT_TRUE(env.SyncFile(dir + "/a.bin").ok());
  EXPECT_EQ(env.Count(Operation::kSync), 2);
  auto read = ReadFileToString(&env, dir + "/a.bin");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(*read, "kept");
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
