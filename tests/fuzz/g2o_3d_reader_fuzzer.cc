// libFuzzer target: storage::ReadG2o3d (VERTEX_SE3:QUAT, EDGE_SE3:QUAT,
// VERTEX_TRACKXYZ, EDGE_SE3_TRACKXYZ, ...) on arbitrary bytes must return a
// value or an error, never crash, hang or trip a sanitizer.
#include "storage/g2o_3d_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = graphslam::fuzz::ScratchPath("input3d.g2o");
  graphslam::fuzz::WriteBytes(path, graphslam::fuzz::AsView(data, size));
  (void)graphslam::storage::ReadG2o3d(path);
  return 0;
}
