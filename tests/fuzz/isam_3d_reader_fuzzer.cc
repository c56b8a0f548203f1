// libFuzzer target: storage::ReadIsam3d (Pose3d_Node, EDGE3, POINT3 records)
// on arbitrary bytes must return a value or an error, never crash, hang or
// trip a sanitizer.
#include "storage/isam_3d_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = graphslam::fuzz::ScratchPath("input3d.isam");
  graphslam::fuzz::WriteBytes(path, graphslam::fuzz::AsView(data, size));
  (void)graphslam::storage::ReadIsam3d(path);
  return 0;
}
