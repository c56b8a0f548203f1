#include "tests/testing/build_paths.h"

namespace graphslam::testing {

const std::string& BinaryDir() {
  static const std::string path = GRAPHSLAM_BINARY_DIR;
  return path;
}

const std::string& DatasetsDir() {
  static const std::string path = GRAPHSLAM_DATASETS_DIR;
  return path;
}

}  // namespace graphslam::testing
