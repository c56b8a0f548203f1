// libFuzzer target: a 3DTK scan (map::Read3dtkScan) from arbitrary bytes.
// The input is split at its first NUL byte: before it the scan000.pose file,
// after it the scan000.3d file (no NUL: an empty .3d). Must return a scan or
// an error, never crash, hang or trip a sanitizer.
#include <algorithm>
#include <filesystem>

#include "storage/threedtk_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    const std::string path = graphslam::fuzz::ScratchPath("3dtk");
    std::filesystem::create_directories(path);
    return path;
  }();
  const std::string_view input = graphslam::fuzz::AsView(data, size);
  const size_t split = std::min(input.find('\0'), input.size());
  graphslam::fuzz::WriteBytes(dir + "/scan000.pose", input.substr(0, split));
  graphslam::fuzz::WriteBytes(dir + "/scan000.3d",
                              split < input.size() ? input.substr(split + 1) : std::string_view());
  (void)graphslam::map::List3dtkScans(dir);
  (void)graphslam::map::Read3dtkScan(dir, 0, 0);
  return 0;
}
