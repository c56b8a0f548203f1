// libFuzzer target: storage::ReadIsam on arbitrary bytes.
#include "storage/isam_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = graphslam::fuzz::ScratchPath("input.isam");
  graphslam::fuzz::WriteBytes(path, graphslam::fuzz::AsView(data, size));
  (void)graphslam::storage::ReadIsam(path);
  return 0;
}
