// Issue 22, defect 8: every numeric option is range-checked while the command
// line is parsed (tools/option_checks.h): nan, inf, negatives and zeros where
// they make no sense are CLI::ValidationError naming the option and the
// expected range, i.e. exit 1 (usage) from the binary, before any input is
// read.
#include "tools/option_checks.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>
#include <unistd.h>
#include <vector>

#include "tests/testing/subprocess.h"
#include "tools/evaluate_command.h"
#include "tools/exit_codes.h"
#include "tools/ingest_command.h"
#include "tools/map_command.h"
#include "tools/simulate_command.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

using ::testing::HasSubstr;

// Parses `args` (after the program name) with every subcommand registered;
// the callbacks are not run (their exit code is ignored). Returns the
// validation message, "" if the command line parsed.
std::string ParseError(std::vector<std::string> args) {
  CLI::App app{"test"};
  app.require_subcommand(1);
  int exit_code = 0;
  SolveCommandOptions solve;
  AddSolveCommand(&app, &solve, &exit_code);
  SimulateCommandOptions simulate;
  AddSimulateCommand(&app, &simulate, &exit_code);
  EvaluateCommandOptions evaluate;
  AddEvaluateCommand(&app, &evaluate, &exit_code);
  IngestCommandOptions ingest;
  AddIngestCommand(&app, &ingest, &exit_code);
  MapCommandOptions map;
  AddMapCommand(&app, &map, &exit_code);
  const std::function<bool(CLI::App*)> all;
  for (CLI::App* sub : app.get_subcommands(all)) sub->callback(nullptr);
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);
  } catch (const CLI::ValidationError& error) {
    return error.what();
  } catch (const CLI::ParseError& error) {
    return std::string("other parse error: ") + error.what();
  }
  return "";
}

TEST(OptionChecks, SolveToleranceAndTrustRegionOfTheIssue) {
  EXPECT_EQ(ParseError({"solve", "in.g2o", "--function-tolerance", "nan"}),
            "--function-tolerance: 'nan' is not a finite number; expected a number in [0, 1)");
  EXPECT_EQ(ParseError({"solve", "in.g2o", "--function-tolerance", "-1"}),
            "--function-tolerance: '-1' is out of range; expected a number in [0, 1)");
  EXPECT_EQ(ParseError({"solve", "in.g2o", "--initial-trust-region", "0"}),
            "--initial-trust-region: '0' is out of range; expected a number in (0, 1e+16]");
  EXPECT_EQ(ParseError({"solve", "in.g2o", "--initial-trust-region", "inf"}),
            "--initial-trust-region: 'inf' is not a finite number; expected a number in (0, "
            "1e+16]");
  EXPECT_EQ(ParseError({"solve", "in.g2o", "--initial-trust-region=abc"}),
            "--initial-trust-region: 'abc' is not a number; expected a number in (0, 1e+16]");
  // In range: parsed.
  EXPECT_EQ(ParseError({"solve", "in.g2o", "--function-tolerance", "0", "--initial-trust-region",
                        "1e16", "--pcg-eta-max", "0.5", "--max-iterations", "0"}),
            "");
}

TEST(OptionChecks, EveryNumericOptionOfSolveNamesItself) {
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"--pcg-eta-min", "0"},         {"--pcg-eta-max", "1"},
      {"--pcg-deflation", "-2"},      {"--pcg-truncation", "nan"},
      {"--max-iterations", "-1"},     {"--max-iterations", "1.5"},
      {"--threads", "-1"},            {"--robot", "6"},
      {"--chunk-observations", "0"},  {"--max-eliminated-observations", "-1"},
      {"--progressive-max-new-poses", "-1"}, {"--streaming-poses", "-5"},
      {"--streaming-observations", "inf"},   {"--chi", "2"},
      {"--association-radius", "0"}};
  for (const auto& [option, value] : bad) {
    const std::string message = ParseError({"solve", "in.g2o", option, value});
    EXPECT_THAT(message, HasSubstr(option + ": '" + value + "'")) << option;
    EXPECT_THAT(message, HasSubstr("; expected a ")) << option;
  }
}

TEST(OptionChecks, OtherSubcommands) {
  EXPECT_THAT(ParseError({"ingest", "in.g2o", "-o", "s", "--checkpoint-seconds", "-1"}),
              HasSubstr("--checkpoint-seconds: '-1' is out of range"));
  EXPECT_THAT(ParseError({"evaluate", "--trajectory", "a.tum", "--max-time-difference", "nan"}),
              HasSubstr("--max-time-difference: 'nan' is not a finite number"));
  EXPECT_THAT(ParseError({"map", "in", "--bt", "m.bt", "--resolution", "0"}),
              HasSubstr("--resolution: '0' is out of range"));
  EXPECT_THAT(ParseError({"map", "in", "--bt", "m.bt", "--prob-hit", "1"}),
              HasSubstr("--prob-hit: '1' is out of range; expected a number in (0.5, 1)"));
  EXPECT_THAT(ParseError({"simulate", "-o", "d", "--dt", "-0.1"}),
              HasSubstr("--dt: '-0.1' is out of range"));
  EXPECT_THAT(ParseError({"simulate", "-o", "d", "--alpha", "0.1", "0.1", "nan", "0", "0", "0"}),
              HasSubstr("--alpha: 'nan' is not a finite number"));
  EXPECT_THAT(ParseError({"simulate", "-o", "d", "--3d", "--beams", "0"}),
              HasSubstr("--beams: '0' is out of range"));
}

TEST(OptionChecks, TheBinaryExitsWithUsageNamingTheOption) {
  ASSERT_TRUE(std::filesystem::exists(testing::GraphslamBinary()));
  const std::string err = std::filesystem::temp_directory_path() /
                          ("graphslam_option_checks_" + std::to_string(getpid()) + ".err");
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"solve", "/nonexistent.g2o", "--function-tolerance", "nan"},
        std::vector<std::string>{"solve", "/nonexistent.g2o", "--initial-trust-region", "inf"}}) {
    EXPECT_EQ(testing::WaitForExit(testing::SpawnGraphslamRedirected(args, err)), kExitUsage);
    std::ifstream in(err);
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_THAT(text, HasSubstr(args[2] + ": '" + args[3] + "'"));
  }
  std::filesystem::remove(err);
}

}  // namespace
}  // namespace graphslam::tools
