// Locating the shared real datasets (../shared/datasets) from tests.
//
// GS_REQUIRE_DATASET(path) skips the test when the file is missing, except
// under CI=true, where a missing dataset is a failure, never a skip.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "tests/testing/build_paths.h"

namespace graphslam::testing {

// Appended in place: GCC 12 reports a false -Warray-bounds on
// std::string(literal) + "/" + relative when it inlines the operators.
inline std::string DatasetPath(const std::string& relative) {
  std::string path = DatasetsDir();
  path += '/';
  path += relative;
  return path;
}

inline bool RunningInCi() {
  const char* ci = std::getenv("CI");
  return ci != nullptr && std::string(ci) == "true";
}

}  // namespace graphslam::testing

#define GS_REQUIRE_DATASET(relative)                                                  \
  do {                                                                                \
    const std::string gs_dataset_path_ = ::graphslam::testing::DatasetPath(relative); \
    if (!std::filesystem::exists(gs_dataset_path_)) {                                 \
      if (::graphslam::testing::RunningInCi()) {                                      \
        FAIL() << "dataset missing under CI=true: " << gs_dataset_path_;              \
      } else {                                                                        \
        GTEST_SKIP() << "dataset missing: " << gs_dataset_path_;                      \
      }                                                                               \
    }                                                                                 \
  } while (0)
