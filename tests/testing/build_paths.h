// Where this build's binaries and the shared real datasets are, for tests.
//
// The paths are compiled into build_paths.cc alone, so that every other test
// unit's flags are the same in any checkout and build directory (a compiler
// cache can then share their objects between worktrees).
#pragma once

#include <string>

namespace graphslam::testing {

// The CMake build directory (its bin/ holds the graphslam binary).
const std::string& BinaryDir();

// ../shared/datasets next to the source tree.
const std::string& DatasetsDir();

}  // namespace graphslam::testing
