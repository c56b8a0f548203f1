// `solve --model-tolerance`: its default is the solver's, a value given
// reaches core::SolverOptions, and values outside [0, 1) are refused.
#include <gtest/gtest.h>

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "core/graphslam_solver.h"
#include "tools/pipeline/solve_request.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

// Parses `solve in.g2o ARGS`; returns false on a parse or validation error.
bool ParseSolve(std::vector<std::string> args, SolveCommandOptions* options) {
  CLI::App app{"test"};
  int exit_code = 0;
  AddSolveCommand(&app, options, &exit_code);
  for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
    sub->callback(nullptr);
  args.insert(args.begin(), {"solve", "in.g2o"});
  std::vector<std::string> reversed(args.rbegin(), args.rend());
  try {
    app.parse(reversed);
  } catch (const CLI::ParseError&) {
    return false;
  }
  return true;
}

TEST(ModelToleranceOption, DefaultAndValueReachTheSolverOptions) {
  SolveCommandOptions defaults;
  ASSERT_TRUE(ParseSolve({}, &defaults));
  StatusOr<core::SolverOptions> from_default = MakeSolverOptions(SolverSettingsFrom(defaults));
  ASSERT_TRUE(from_default.ok()) << from_default.status().ToString();
  EXPECT_EQ(from_default->model_tolerance, core::SolverOptions().model_tolerance);
  EXPECT_EQ(from_default->max_iterations, core::SolverOptions().max_iterations);
  EXPECT_EQ(from_default->function_tolerance, core::SolverOptions().function_tolerance);

  SolveCommandOptions given;
  ASSERT_TRUE(ParseSolve({"--model-tolerance", "0"}, &given));
  StatusOr<core::SolverOptions> from_given = MakeSolverOptions(SolverSettingsFrom(given));
  ASSERT_TRUE(from_given.ok()) << from_given.status().ToString();
  EXPECT_EQ(from_given->model_tolerance, 0.0);
}

TEST(ModelToleranceOption, OutOfRangeIsRefused) {
  for (const char* bad : {"-1e-4", "1", "nan"}) {
    SolveCommandOptions options;
    EXPECT_FALSE(ParseSolve({"--model-tolerance", bad}, &options)) << bad;
  }
}

}  // namespace
}  // namespace graphslam::tools
