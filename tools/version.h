// `graphslam --version`: the project version, the commit the build was
// configured from (captured by CMake at configure time, so a rebuild after a
// new commit without re-configuring still shows the older commit, marked as
// the configure-time one) and the versions of the libraries it was built
// against.
#pragma once

#include <string>

namespace graphslam::tools {

// Several lines, ending in a newline:
//   graphslam 0.1.0 (commit 0fc3a7e1b2c3 at configure time)
//   built with Eigen 3.4.0, SuiteSparse 5.12.0 (CHOLMOD 3.0.14), TBB 2021.8.0, PCL 1.13.0, OctoMap 1.9.7
std::string VersionText();

}  // namespace graphslam::tools
