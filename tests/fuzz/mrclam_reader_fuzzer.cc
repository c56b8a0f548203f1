// libFuzzer target: storage::ReadMrclam on an arbitrary dataset folder. The
// input is split at '\0' bytes into Barcodes.dat, Robot1_Odometry.dat,
// Robot1_Measurement.dat and Robot1_Groundtruth.dat (missing parts: empty or
// absent files).
#include "storage/mrclam_reader.h"
#include "tests/fuzz/fuzz_input_file.h"

#include <filesystem>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string folder = graphslam::fuzz::ScratchPath("mrclam");
  static const char* kFiles[] = {"Barcodes.dat", "Robot1_Odometry.dat", "Robot1_Measurement.dat",
                                 "Robot1_Groundtruth.dat"};
  std::error_code error;
  std::filesystem::remove_all(folder, error);
  std::filesystem::create_directories(folder, error);
  std::string_view rest = graphslam::fuzz::AsView(data, size);
  for (size_t i = 0; i < 4; ++i) {
    const size_t end = rest.find('\0');
    const std::string_view part = rest.substr(0, end);
    // The ground truth file is optional: only written when present.
    if (i < 3 || !part.empty()) graphslam::fuzz::WriteBytes(folder + "/" + kFiles[i], part);
    rest = end == std::string_view::npos ? std::string_view() : rest.substr(end + 1);
  }
  graphslam::storage::MrclamOptions options;
  (void)graphslam::storage::ReadMrclam(folder, options);
  return 0;
}
