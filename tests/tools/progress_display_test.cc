// ProgressDisplay with an injected clock: plain log lines (throttled per
// stage, the first at once whatever the clock reads), rate and ETA only once
// known, the terminal line cleared before each redraw, and the iteration
// table.
#include "tools/progress_display.h"

#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "core/graphslam_solver.h"

namespace graphslam::tools {
namespace {

using Clock = ProgressDisplay::Clock;

int CountLines(const std::string& text, const std::string& needle) {
  int count = 0;
  for (size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + 1))
    ++count;
  return count;
}

// A clock that reads what the test sets. Starts at `uptime` seconds: a
// steady_clock counts from boot, so a fresh machine reads a small number.
struct FakeClock {
  explicit FakeClock(double uptime) : now(Clock::time_point(ToDuration(uptime))) {}
  static Clock::duration ToDuration(double seconds) {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  }
  void Advance(double seconds) { now += ToDuration(seconds); }
  ProgressDisplay::NowFunction Function() {
    return [this] { return now; };
  }
  Clock::time_point now;
};

class ProgressDisplayUptime : public ::testing::TestWithParam<double> {};

// The first line of each stage must not wait for an interval to pass since
// the clock's epoch: on a machine booted a minute ago that hid every line.
TEST_P(ProgressDisplayUptime, LogsOneLinePerStagePerIntervalFromAnyUptime) {
  FakeClock clock(GetParam());
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(/*enabled=*/true, /*min_log_interval=*/1000.0, /*terminal=*/false,
                            clock.Function());
    ProgressCallback callback = display.AsCallback();
    callback("optimize", 1, 0);
    clock.Advance(1.0);
    callback("optimize", 2, 0);  // within the interval: silent
    callback("reduce", 1, 1);    // a single-chunk pass: silent
    callback("reduce", 3, 10);   // a real pass: one line
    callback("reduce", 4, 10);
    callback("optimize", 3, 0);  // stage switched back: still throttled
    clock.Advance(1000.0);
    callback("optimize", 4, 0);  // the interval has passed
  }
  const std::string output = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(CountLines(output, "stage=\"optimize\""), 2) << output;
  EXPECT_EQ(CountLines(output, "stage=\"reduce\""), 1) << output;
  EXPECT_NE(output.find("stage=\"optimize\" done=1\n"), std::string::npos) << output;
  EXPECT_NE(output.find("stage=\"optimize\" done=4 rate="), std::string::npos) << output;
  EXPECT_NE(output.find("stage=\"reduce\" done=3 total=10\n"), std::string::npos) << output;
}

INSTANTIATE_TEST_SUITE_P(Uptimes, ProgressDisplayUptime,
                         ::testing::Values(0.0, 30.0, 60.0, 999.0, 1e6));

TEST(ProgressDisplay, RateAndEtaOnlyOnceKnown) {
  FakeClock clock(60.0);
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(true, 0.0, false, clock.Function());
    display.Update("reduce", 0, 20);  // nothing done yet: no rate, no ETA
    clock.Advance(2.0);
    display.Update("reduce", 10, 20);  // 10 in 2 s: 5/s, 10 left: 2 s
    clock.Advance(1.0);
    display.Update("reduce", 2, 20);  // went backwards: a new pass, rate unknown again
    clock.Advance(4.0);
    display.Update("reduce", 6, 20);  // 4 in 4 s: 1/s, 14 left
  }
  const std::string output = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(output.find("done=0 total=20\n"), std::string::npos) << output;
  EXPECT_NE(output.find("done=10 total=20 rate=5/s eta=2s"), std::string::npos) << output;
  EXPECT_NE(output.find("done=2 total=20\n"), std::string::npos) << output;
  EXPECT_NE(output.find("done=6 total=20 rate=1/s eta=14s"), std::string::npos) << output;
  EXPECT_EQ(output.find("rate=0"), std::string::npos) << output;
}

TEST(ProgressDisplay, TerminalLineIsClearedAndNamesTheContext) {
  FakeClock clock(10.0);
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(true, 5.0, /*terminal=*/true, clock.Function());
    display.SetContext("campus_1 with GPS");
    display.Update("screen", 1, 1);  // a single-chunk pass: not shown
    display.Update("screen", 3, 8);
    clock.Advance(1.0);
    display.Update("screen", 8, 8);  // complete: the line is cleared, not kept
    display.Update("reduce", 605, 6969);
  }
  const std::string output = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(output.find("1/1"), std::string::npos) << output;
  EXPECT_NE(output.find("\r\033[K[campus_1 with GPS: screen] 3/8\r\033[K"), std::string::npos)
      << output;
  EXPECT_EQ(output.find("\n"), std::string::npos) << output;
  EXPECT_NE(output.find("\r\033[K[campus_1 with GPS: reduce] 605/6969"), std::string::npos)
      << output;
  // Finish clears the open line instead of leaving it under later output.
  EXPECT_EQ(output.substr(output.size() - 4), "\r\033[K") << output;
}

core::IterationSummary Row(int iteration, double start, double candidate, bool accepted) {
  core::IterationSummary it;
  it.iteration = iteration;
  it.start_chi2 = start;
  it.candidate_chi2 = candidate;
  it.chi2 = accepted ? candidate : start;
  it.accepted = accepted;
  it.gradient_max_norm = 12.5;
  it.step_norm = 0.25;
  it.lambda = 1e-4;
  it.relative_decrease = accepted ? 0.99 : -0.5;
  it.linear_iterations = 7;
  it.seconds = 0.5;
  return it;
}

TEST(ProgressDisplay, TerminalIterationTableHasOneHeaderPerContext) {
  FakeClock clock(10.0);
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(true, 5.0, true, clock.Function());
    display.SetContext("with GPS");
    display.Update("reduce", 3, 10);  // an open progress line, cleared by the row
    display.Iteration(Row(1, 1000.0, 400.0, true));
    display.Iteration(Row(2, 400.0, 500.0, false));
    display.SetContext("without GPS");
    display.Iteration(Row(1, 900.0, 300.0, true));
  }
  const std::string output = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(CountLines(output, "chi2_change"), 2) << output;
  EXPECT_NE(output.find("with GPS\n"), std::string::npos) << output;
  EXPECT_NE(output.find("without GPS\n"), std::string::npos) << output;
  // Row 0 is the start of each solve.
  EXPECT_NE(output.find("   0  1.000000e+03\n"), std::string::npos) << output;
  EXPECT_NE(output.find("   0  9.000000e+02\n"), std::string::npos) << output;
  // chi2 after, change at the trial, |gradient|, |step|, lambda, rho, CG, times.
  EXPECT_NE(output.find("   1  4.000000e+02    6.0000e+02   1.250e+01  2.500e-01  1.00e-04"
                        "   0.990       7    0.50s    0.50s\n"),
            std::string::npos)
      << output;
  EXPECT_NE(output.find("   2  4.000000e+02   -1.0000e+02"), std::string::npos) << output;
  EXPECT_NE(output.find("1.00s  rejected\n"), std::string::npos) << output;
  EXPECT_NE(output.find("\r\033[Kwith GPS\n"), std::string::npos) << output;
}

TEST(ProgressDisplay, PlainIterationLines) {
  FakeClock clock(10.0);
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(true, 5.0, false, clock.Function());
    display.SetContext("run_a");
    display.Iteration(Row(1, 1000.0, 400.0, true));
    display.Iteration(Row(2, 400.0, 500.0, false));
  }
  const std::string output = ::testing::internal::GetCapturedStderr();
  EXPECT_NE(output.find("iteration run_a 1 chi2=400 chi2_change=600"), std::string::npos)
      << output;
  EXPECT_NE(output.find("total_seconds=1.000 rejected"), std::string::npos) << output;
}

TEST(ProgressDisplay, DisabledDisplayIsSilent) {
  ::testing::internal::CaptureStderr();
  {
    ProgressDisplay display(/*enabled=*/false);
    display.Update("optimize", 1, 10);
    display.Update("optimize", 10, 10);
    display.Iteration(Row(1, 2.0, 1.0, true));
  }
  EXPECT_EQ(::testing::internal::GetCapturedStderr(), "");
}

TEST(FormatDuration, HumanUnits) {
  EXPECT_EQ(FormatDuration(0.4), "0s");
  EXPECT_EQ(FormatDuration(26.0), "26s");
  EXPECT_EQ(FormatDuration(185.0), "3m05s");
  EXPECT_EQ(FormatDuration(7260.0), "2h01m");
  EXPECT_EQ(FormatDuration(-1.0), "?");
}

}  // namespace
}  // namespace graphslam::tools
