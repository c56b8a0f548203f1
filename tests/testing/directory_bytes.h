// Whole files and byte-for-byte comparison of directory trees, for the resume tests: a store
// written by an interrupted-then-resumed run must equal the uninterrupted
// run's in every file (names and bytes).
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

namespace graphslam::testing {

// The whole content of a file, byte for byte ("" if it cannot be read).
inline std::string ReadWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Every regular file under `dir`, by path relative to `dir`, with its bytes.
inline std::map<std::string, std::string> FilesUnder(const std::filesystem::path& dir) {
  std::map<std::string, std::string> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(dir))
    if (entry.is_regular_file())
      files[std::filesystem::relative(entry.path(), dir).string()] = ReadWholeFile(entry.path());
  return files;
}

// The same file names, and each file's bytes equal (naming the first that differs).
inline void ExpectSameFiles(const std::map<std::string, std::string>& actual,
                            const std::map<std::string, std::string>& expected) {
  ASSERT_EQ(actual.size(), expected.size());
  for (auto a = actual.begin(), e = expected.begin(); a != actual.end(); ++a, ++e) {
    ASSERT_EQ(a->first, e->first);
    EXPECT_TRUE(a->second == e->second) << a->first << " differs";
  }
}

}  // namespace graphslam::testing
