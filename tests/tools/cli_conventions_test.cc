// The command line's conventions (docs/cli.md), on the real binary: --version,
// "did you mean" for mistyped subcommands and options, one error format
// `graphslam <subcommand>: <message>` on one line with exit 1 for every usage
// error, -v / -q on every subcommand, --format naming `auto`, and `run -o`
// standing in for a job file's missing `output:`, and silence under -q on the
// README's main job (tools/setup/default_job.yaml, maps included).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "tests/testing/subprocess.h"
#include "tools/cli_errors.h"
#include "tools/exit_codes.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;
using testing::GraphslamRun;

const std::vector<std::string> kSubcommands = {"solve", "simulate", "evaluate",
                                               "ingest", "map", "run"};

class CliConventions : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("graphslam_cli_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  GraphslamRun Run(const std::vector<std::string>& args) {
    return testing::RunGraphslamCaptured(args, (dir_ / "capture").string());
  }
  std::string Write(const std::string& name, const std::string& text) {
    const fs::path path = dir_ / name;
    std::ofstream(path) << text;
    return path.string();
  }

  fs::path dir_;
};

// One line on stderr: the message and its newline, nothing more.
void ExpectOneLine(const GraphslamRun& run) {
  ASSERT_FALSE(run.err.empty());
  EXPECT_EQ(run.err.find('\n'), run.err.size() - 1) << run.err;
}

TEST(EditDistance, CountsEditsAndTranspositions) {
  EXPECT_EQ(EditDistance("solve", "solve"), 0);
  EXPECT_EQ(EditDistance("slove", "solve"), 1);  // one transposition
  EXPECT_EQ(EditDistance("--max-iteration", "--max-iterations"), 1);
  EXPECT_EQ(EditDistance("kitten", "sitting"), 3);
  EXPECT_EQ(EditDistance("", "abc"), 3);
}

TEST(Suggest, NearestWithinThreshold) {
  const std::vector<std::string> names = {"solve", "simulate", "evaluate", "ingest", "map", "run"};
  EXPECT_EQ(Suggest("slove", names), "solve");
  EXPECT_EQ(Suggest("simulte", names), "simulate");
  EXPECT_EQ(Suggest("mpa", names), "map");
  EXPECT_EQ(Suggest("benchmark", names), "");  // nothing near: no guess
}

TEST_F(CliConventions, VersionNamesCommitAndLibraries) {
  const GraphslamRun run = Run({"--version"});
  EXPECT_EQ(run.exit_code, kExitOk);
  EXPECT_EQ(run.out.rfind("graphslam 0.", 0), 0u) << run.out;
  EXPECT_NE(run.out.find("(commit "), std::string::npos) << run.out;
  EXPECT_EQ(run.out.find("(commit  "), std::string::npos) << run.out;
  for (const char* library : {"Eigen 3.", "SuiteSparse 5.", "CHOLMOD 3.", "TBB 20", "PCL 1.",
                              "OctoMap 1."})
    EXPECT_NE(run.out.find(library), std::string::npos) << library << " in " << run.out;
}

TEST_F(CliConventions, MistypedSubcommandSuggestsTheNearest) {
  const GraphslamRun run = Run({"slove", "in.g2o"});
  EXPECT_EQ(run.exit_code, kExitUsage);
  ExpectOneLine(run);
  EXPECT_EQ(run.err,
            "graphslam: unknown subcommand 'slove'; did you mean 'solve'? (expected one of "
            "solve, simulate, evaluate, ingest, map, run or benchmark)\n");
}

TEST_F(CliConventions, NoSubcommandIsAUsageError) {
  const GraphslamRun run = Run({});
  EXPECT_EQ(run.exit_code, kExitUsage);
  ExpectOneLine(run);
  EXPECT_EQ(run.err.rfind("graphslam: a subcommand is required; expected one of solve, ", 0), 0u)
      << run.err;
}

TEST_F(CliConventions, MistypedOptionSuggestsTheNearest) {
  const GraphslamRun run = Run({"solve", "in.g2o", "--max-iteration", "3"});
  EXPECT_EQ(run.exit_code, kExitUsage);
  ExpectOneLine(run);
  EXPECT_EQ(run.err,
            "graphslam solve: unknown option '--max-iteration'; did you mean "
            "'--max-iterations'? (graphslam solve --help)\n");
  const GraphslamRun equals = Run({"map", "in", "--resolutoin=0.2"});
  EXPECT_EQ(equals.exit_code, kExitUsage);
  EXPECT_EQ(equals.err,
            "graphslam map: unknown option '--resolutoin'; did you mean '--resolution'? "
            "(graphslam map --help)\n");
}

// Every subcommand: an unknown option, a value of the wrong type and a
// missing required argument each give one prefixed line and exit 1.
TEST_F(CliConventions, EveryBadOptionOneLineExitOne) {
  for (const std::string& sub : kSubcommands) {
    SCOPED_TRACE(sub);
    const GraphslamRun unknown = Run({sub, "--no-such-option"});
    EXPECT_EQ(unknown.exit_code, kExitUsage);
    ExpectOneLine(unknown);
    EXPECT_EQ(unknown.err.rfind("graphslam " + sub + ": unknown option '--no-such-option'", 0), 0u)
        << unknown.err;
    const GraphslamRun missing = Run({sub});
    EXPECT_EQ(missing.exit_code, kExitUsage);
    ExpectOneLine(missing);
    EXPECT_EQ(missing.err.rfind("graphslam " + sub + ": ", 0), 0u) << missing.err;
  }
  const GraphslamRun not_a_number = Run({"solve", "in.g2o", "--max-iterations", "abc"});
  EXPECT_EQ(not_a_number.exit_code, kExitUsage);
  ExpectOneLine(not_a_number);
  EXPECT_EQ(not_a_number.err.rfind("graphslam solve: ", 0), 0u) << not_a_number.err;
  EXPECT_NE(not_a_number.err.find("abc"), std::string::npos) << not_a_number.err;
  const GraphslamRun too_few = Run({"simulate", "-o", (dir_ / "s").string(), "--alpha", "1"});
  EXPECT_EQ(too_few.exit_code, kExitUsage);
  ExpectOneLine(too_few);
  EXPECT_EQ(too_few.err.rfind("graphslam simulate: ", 0), 0u) << too_few.err;
}

TEST_F(CliConventions, VerboseAndQuietOnEverySubcommand) {
  for (const std::string& sub : kSubcommands) {
    SCOPED_TRACE(sub);
    // Both flags parse; the error is then about what is missing, not them.
    const GraphslamRun run = Run({sub, "-v", "-v", "-q"});
    EXPECT_EQ(run.exit_code, kExitUsage);
    EXPECT_EQ(run.err.find("unknown option"), std::string::npos) << run.err;
    EXPECT_EQ(run.err.find("-v"), std::string::npos) << run.err;
  }
}

TEST_F(CliConventions, FormatChoicesIncludeAuto) {
  const std::string input = Write("in.g2o", "VERTEX_SE2 0 0 0 0\n");
  for (const std::string sub : {"solve", "ingest"}) {
    std::vector<std::string> args = {sub, input, "--format", "xyz"};
    if (sub == "ingest") args.insert(args.end(), {"-o", (dir_ / "store").string()});
    const GraphslamRun run = Run(args);
    EXPECT_EQ(run.exit_code, kExitUsage) << sub;
    ExpectOneLine(run);
    EXPECT_EQ(run.err.rfind("graphslam " + sub + ": --format: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find("expected auto, g2o, isam, mrclam, native or toro"),
              std::string::npos)
        << run.err;
  }
}

TEST_F(CliConventions, RunOutputComesFromMinusOWhenTheFileHasNone) {
  const std::string job =
      Write("job.yaml",
            "runs:\n  - {name: s, format: simulate, simulate: {poses: 60, seed: 2}}\n"
            "stages: [ingest, initialize, optimize, export]\n");
  const GraphslamRun without = Run({"run", job, "-q"});
  EXPECT_EQ(without.exit_code, kExitBadInput);
  ExpectOneLine(without);
  EXPECT_NE(without.err.find("no 'output' and no -o"), std::string::npos) << without.err;

  const fs::path out = dir_ / "out";
  const GraphslamRun with = Run({"run", job, "-o", out.string(), "-q"});
  EXPECT_EQ(with.exit_code, kExitOk) << with.err;
  EXPECT_TRUE(fs::exists(out / "graph.g2o"));
  EXPECT_TRUE(fs::exists(out / "trajectories" / "s.tum"));

  // -o overrides a file's own output: nothing goes to the file's folder.
  const std::string named = Write("named.yaml",
                                  "output: from_file\n"
                                  "runs:\n  - {name: s, format: simulate, simulate: {poses: 60, "
                                  "seed: 2}}\nstages: [ingest, initialize, optimize, export]\n");
  const fs::path other = dir_ / "other";
  const GraphslamRun overridden = Run({"run", named, "-o", other.string(), "-q"});
  EXPECT_EQ(overridden.exit_code, kExitOk) << overridden.err;
  EXPECT_TRUE(fs::exists(other / "graph.g2o"));
  EXPECT_FALSE(fs::exists(dir_ / "from_file"));
}

// -q means nothing on stdout or stderr, whatever the libraries underneath do:
// Debian's OctoMap wrote " done." after every .bt. The README's main job file
// as shipped, with fewer poses so that it takes seconds (every stage and the
// GPS / no-GPS pair still run, and the map is fused from the scans).
TEST_F(CliConventions, MainJobPrintsNothingUnderQuiet) {
  std::ifstream shipped(std::string(GRAPHSLAM_SOURCE_DIR) + "/tools/setup/default_job.yaml");
  ASSERT_TRUE(shipped.good());
  std::stringstream text;
  text << shipped.rdbuf();
  std::string job = text.str();
  for (const auto& [from, to] : {std::pair<std::string, std::string>{"poses: 3000", "poses: 300"},
                                 {"output: ../../out\n", ""}}) {
    const size_t at = job.find(from);
    ASSERT_NE(at, std::string::npos) << from << " in default_job.yaml";
    job.replace(at, from.size(), to);
  }
  const fs::path out = dir_ / "out";
  const GraphslamRun run = Run({"run", Write("default_job.yaml", job), "-o", out.string(), "-q"});
  EXPECT_EQ(run.exit_code, kExitOk) << run.err;
  EXPECT_EQ(run.out, "");
  EXPECT_EQ(run.err, "");
  EXPECT_GT(fs::file_size(out / "map.bt"), 0u);
  EXPECT_TRUE(fs::exists(out / "report.html"));
}

}  // namespace
}  // namespace graphslam::tools
