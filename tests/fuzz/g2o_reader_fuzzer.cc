// libFuzzer target: storage::ReadG2o on arbitrary bytes must return a value
// or an error, never crash, hang or trip a sanitizer.
#include "storage/g2o_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = graphslam::fuzz::ScratchPath("input.g2o");
  graphslam::fuzz::WriteBytes(path, graphslam::fuzz::AsView(data, size));
  (void)graphslam::storage::ReadG2o(path);
  return 0;
}
