// libFuzzer target: the job file parser (tools/job/job_spec.h) on arbitrary
// text, through yaml-cpp.
#include <string>

#include "tests/fuzz/fuzz_input_file.h"
#include "tools/job/job_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(graphslam::fuzz::AsView(data, size));
  (void)graphslam::tools::job::ParseJobSpec(text, "/fuzz/job.yaml");
  return 0;
}
