// ProgressDisplay off a terminal (ctest's stderr is a pipe): plain log lines,
// at most one per stage per interval, single-chunk passes silent.
#include "tools/progress_display.h"

#include <gtest/gtest.h>

#include <string>

namespace graphslam::tools {
namespace {

int CountLines(const std::string& text, const std::string& needle) {
  int count = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1))
    ++count;
  return count;
}

TEST(ProgressDisplay, LogsOneLinePerStagePerInterval) {
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(/*enabled=*/true, /*min_log_interval=*/1000.0);
    ProgressCallback callback = display.AsCallback();
    callback("optimize", 1, 100);
    callback("optimize", 2, 100);    // within the interval: silent
    callback("reduce", 1, 1);        // a single-chunk pass: silent
    callback("reduce", 3, 10);       // a real pass: one line
    callback("reduce", 4, 10);
    callback("optimize", 3, 100);    // stage switched back: still throttled
  }
  const std::string output = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(CountLines(output, "stage=optimize"), 1) << output;
  EXPECT_EQ(CountLines(output, "stage=reduce"), 1) << output;
  EXPECT_NE(output.find("stage=optimize done=1 total=100"), std::string::npos) << output;
  EXPECT_NE(output.find("stage=reduce done=3 total=10"), std::string::npos) << output;
}

TEST(ProgressDisplay, DisabledDisplayIsSilent) {
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(/*enabled=*/false);
    display.Update("optimize", 1, 10);
    display.Update("optimize", 10, 10);
  }
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

}  // namespace
}  // namespace graphslam::tools
