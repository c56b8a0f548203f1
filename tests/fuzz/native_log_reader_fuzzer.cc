// libFuzzer target: storage::ReadNativeLog on arbitrary bytes. A log that
// reads back is written and read again: the writer must accept what the
// reader returns (round trip).
#include "storage/native_log_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = graphslam::fuzz::ScratchPath("input.graphslam");
  static const std::string copy = graphslam::fuzz::ScratchPath("copy.graphslam");
  graphslam::fuzz::WriteBytes(path, graphslam::fuzz::AsView(data, size));
  auto problem = graphslam::storage::ReadNativeLog(path);
  if (problem.ok() && graphslam::storage::WriteNativeLog(*problem, copy).ok()) {
    auto again = graphslam::storage::ReadNativeLog(copy);
    if (!again.ok() || again->num_poses() != problem->num_poses() ||
        again->num_features() != problem->num_features())
      std::abort();  // the writer produced a log its own reader rejects
  }
  return 0;
}
