#include "storage/env.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

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

TEST(PosixEnv, CreatesListsAndRemovesFolders) {
  const std::string dir = TempDir("folders");
  Env* env = Env::Default();
  ASSERT_TRUE(env->CreateDir(dir + "/a/b/c").ok());  // parents too
  ASSERT_TRUE(env->CreateDir(dir + "/a/b/c").ok());  // already there
  EXPECT_EQ(env->KindOf(dir + "/a/b/c"), FileKind::kDirectory);
  for (const std::string name : {"y", "x"}) {
    auto file = env->NewWritableFile(dir + "/a/" + name);
    ASSERT_TRUE(file.ok());
    ASSERT_TRUE((*file)->Close().ok());
  }
  auto names = env->ListDir(dir + "/a");
  ASSERT_TRUE(names.ok()) << names.status().ToString();
  EXPECT_EQ(*names, (std::vector<std::string>{"b", "x", "y"}));

  const Status not_empty = env->RemoveDir(dir + "/a");
  EXPECT_TRUE(not_empty.IsIOError());
  EXPECT_NE(not_empty.message().find("/a: rmdir: "), std::string::npos) << not_empty.ToString();
  ASSERT_TRUE(env->RemoveDir(dir + "/a/b/c").ok());
  EXPECT_FALSE(env->FileExists(dir + "/a/b/c"));
  ASSERT_TRUE(env->RemoveTree(dir + "/a").ok());
  EXPECT_FALSE(env->FileExists(dir + "/a"));
  EXPECT_TRUE(env->RemoveTree(dir + "/a").ok());  // nothing to remove

  const auto missing = env->ListDir(dir + "/a");
  EXPECT_TRUE(missing.status().IsIOError());
  EXPECT_NE(missing.status().message().find("/a: list: "), std::string::npos)
      << missing.status().ToString();
  auto file = env->NewWritableFile(dir + "/plain");
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE((*file)->Close().ok());
  const Status under_file = env->CreateDir(dir + "/plain/sub");
  EXPECT_TRUE(under_file.IsIOError());
  EXPECT_NE(under_file.message().find("/plain/sub: mkdir: "), std::string::npos)
      << under_file.ToString();
  std::filesystem::remove_all(dir);
}

// Flush hands the buffer to the kernel: another reader sees the bytes before
// Close (a log read while it is written); after Close it is an error.
TEST(PosixEnv, FlushMakesBufferedBytesVisible) {
  const std::string dir = TempDir("flush");
  const std::string path = dir + "/log.jsonl";
  auto file = Env::Default()->NewAppendableFile(path);
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE((*file)->Append("line 1\n").ok());
  EXPECT_EQ(Slurp(path), "");  // still in the 64 KiB buffer
  ASSERT_TRUE((*file)->Flush().ok());
  EXPECT_EQ(Slurp(path), "line 1\n");
  ASSERT_TRUE((*file)->Close().ok());
  EXPECT_TRUE((*file)->Flush().IsIOError());
  FaultInjectionEnv faulty(Env::Default());
  auto wrapped = faulty.NewAppendableFile(path);
  ASSERT_TRUE(wrapped.ok());
  ASSERT_TRUE((*wrapped)->Append("line 2\n").ok());
  ASSERT_TRUE((*wrapped)->Flush().ok());
  EXPECT_EQ(Slurp(path), "line 1\nline 2\n");
  ASSERT_TRUE((*wrapped)->Close().ok());
  std::filesystem::remove_all(dir);
}

// ListTree: the regular files at any depth, relative and sorted; folders
// (empty or not) are not listed; a missing folder is an IOError.
TEST(PosixEnv, ListsTheFilesOfATree) {
  const std::string dir = TempDir("tree");
  Env* env = Env::Default();
  ASSERT_TRUE(env->CreateDir(dir + "/t/sub/deeper").ok());
  ASSERT_TRUE(env->CreateDir(dir + "/t/empty").ok());
  for (const std::string name : {"z.bin", "sub/b.json", "sub/deeper/a.bin", "a.txt"}) {
    auto file = env->NewWritableFile(dir + "/t/" + name);
    ASSERT_TRUE(file.ok());
    ASSERT_TRUE((*file)->Close().ok());
  }
  auto files = env->ListTree(dir + "/t");
  ASSERT_TRUE(files.ok()) << files.status().ToString();
  EXPECT_EQ(*files,
            (std::vector<std::string>{"a.txt", "sub/b.json", "sub/deeper/a.bin", "z.bin"}));
  FaultInjectionEnv faulty(env);
  auto forwarded = faulty.ListTree(dir + "/t/sub");
  ASSERT_TRUE(forwarded.ok());
  EXPECT_EQ(*forwarded, (std::vector<std::string>{"b.json", "deeper/a.bin"}));

  const auto missing = env->ListTree(dir + "/none");
  EXPECT_TRUE(missing.status().IsIOError());
  EXPECT_NE(missing.status().message().find("/none: list: "), std::string::npos)
      << missing.status().ToString();
  std::filesystem::remove_all(dir);
}

// The message of a missing file is the caller's; other errors are the Env's.
TEST(PosixEnv, ReadsAFileWithTheCallersMessageWhenMissing) {
  const std::string dir = TempDir("missing");
  Env* env = Env::Default();
  auto file = env->NewWritableFile(dir + "/present.json");
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE((*file)->Append("{}\n").ok());
  ASSERT_TRUE((*file)->Close().ok());
  auto present = ReadFileToString(env, dir + "/present.json", "unused");
  ASSERT_TRUE(present.ok());
  EXPECT_EQ(*present, "{}\n");
  const auto missing = ReadFileToString(env, dir + "/gone.json", "gone.json: missing (ran?)");
  EXPECT_TRUE(missing.status().IsNotFound());
  EXPECT_EQ(missing.status().message(), "gone.json: missing (ran?)");
  const auto folder = ReadFileToString(env, dir, "unused");
  EXPECT_FALSE(folder.ok());
  EXPECT_FALSE(folder.status().IsNotFound());
  std::filesystem::remove_all(dir);
}

TEST(PosixEnv, SizesAndTruncatesFiles) {
  const std::string dir = TempDir("truncate");
  const std::string path = dir + "/bucket.bin";
  Env* env = Env::Default();
  auto file = env->NewWritableFile(path);
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE((*file)->Append("0123456789").ok());
  ASSERT_TRUE((*file)->Close().ok());
  auto size = env->FileSize(path);
  ASSERT_TRUE(size.ok()) << size.status().ToString();
  EXPECT_EQ(*size, 10u);
  ASSERT_TRUE(env->TruncateFile(path, 4).ok());
  EXPECT_EQ(Slurp(path), "0123");
  size = env->FileSize(path);
  ASSERT_TRUE(size.ok());
  EXPECT_EQ(*size, 4u);

  EXPECT_TRUE(env->FileSize(dir + "/missing.bin").status().IsIOError());
  EXPECT_TRUE(env->FileSize(dir).status().IsIOError());  // a folder has no file size
  const Status missing = env->TruncateFile(dir + "/missing.bin", 0);
  EXPECT_TRUE(missing.IsIOError());
  EXPECT_NE(missing.message().find("missing.bin: truncate: No such file"), std::string::npos)
      << missing.ToString();
  std::filesystem::remove_all(dir);
}

// The folder operations reach the wrapped Env and are not counted: a test
// that fails every removal of files still has its scratch folders.
TEST(FaultInjectionEnv, ForwardsFolderOperations) {
  const std::string dir = TempDir("forward");
  FaultInjectionEnv env(Env::Default());
  env.FailAlways(Operation::kRemoveFile);
  ASSERT_TRUE(env.CreateDir(dir + "/work/sub").ok());
  auto file = env.NewWritableFile(dir + "/work/f");
  ASSERT_TRUE(file.ok());
  ASSERT_TRUE((*file)->Append("abc").ok());
  ASSERT_TRUE((*file)->Close().ok());
  auto names = env.ListDir(dir + "/work");
  ASSERT_TRUE(names.ok());
  EXPECT_EQ(*names, (std::vector<std::string>{"f", "sub"}));
  auto size = env.FileSize(dir + "/work/f");
  ASSERT_TRUE(size.ok());
  EXPECT_EQ(*size, 3u);
  ASSERT_TRUE(env.TruncateFile(dir + "/work/f", 1).ok());
  EXPECT_EQ(Slurp(dir + "/work/f"), "a");
  EXPECT_TRUE(env.RemoveFile(dir + "/work/f").IsIOError());  // still injected
  ASSERT_TRUE(env.RemoveDir(dir + "/work/sub").ok());
  ASSERT_TRUE(env.RemoveTree(dir + "/work").ok());
  EXPECT_FALSE(env.FileExists(dir + "/work"));
  EXPECT_EQ(env.Count(Operation::kRemoveFile), 1);
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
