// libFuzzer target: a scan store (map::DiskScanStore: the SCANS.json manifest
// and its CRC-framed scan chunks) from arbitrary bytes. The input is split at
// its first NUL byte: before it DIR/scans/SCANS.json, after it the chunk
// DIR/scans/000000.gss. Open and Load of every chunk the manifest names must
// return scans or an error, never crash, hang or trip a sanitizer.
#include <algorithm>
#include <filesystem>
#include <vector>

#include "storage/scan_store.h"
#include "tests/fuzz/fuzz_input_file.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    const std::string path = graphslam::fuzz::ScratchPath("scanstore");
    std::filesystem::create_directories(path + "/" + graphslam::map::kScanStoreDirectory);
    return path;
  }();
  const std::string scans = dir + "/" + graphslam::map::kScanStoreDirectory;
  const std::string_view input = graphslam::fuzz::AsView(data, size);
  const size_t split = std::min(input.find('\0'), input.size());
  graphslam::fuzz::WriteBytes(scans + "/" + graphslam::map::kScanStoreManifest,
                              input.substr(0, split));
  graphslam::fuzz::WriteBytes(scans + "/000000.gss",
                              split < input.size() ? input.substr(split + 1) : std::string_view());
  auto store = graphslam::map::DiskScanStore::Open(dir);
  if (!store.ok()) return 0;
  std::vector<graphslam::map::Scan> loaded;
  // A manifest may name many chunks; every one but 000000.gss is missing.
  const int64_t chunks = std::min<int64_t>((*store)->NumChunks(), 4);
  for (int64_t k = 0; k < chunks; ++k) (void)(*store)->Load(k, &loaded);
  return 0;
}
