// `graphslam benchmark` end to end on small sizes: every size simulated,
// ingested and solved to convergence (chi2 per degree of freedom about 1, as
// simulated data with the true noise must give), the CSV and the page
// written; killed after the first size, `--resume` keeps that size's row and
// ends with what the uninterrupted sweep gives; a foreign folder is refused.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "tests/testing/kill_nine.h"
#include "tests/testing/subprocess.h"

namespace {

namespace fs = std::filesystem;
using graphslam::testing::RunGraphslam;

std::string Read(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::vector<std::vector<std::string>> Rows(const fs::path& csv) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream lines(Read(csv));
  std::string line;
  std::getline(lines, line);  // header
  while (std::getline(lines, line)) {
    std::vector<std::string> fields;
    std::istringstream cells(line);
    for (std::string cell; std::getline(cells, cell, ',');) fields.push_back(cell);
    rows.push_back(fields);
  }
  return rows;
}

// Columns of the CSV (tools/benchmark/scaling_report.h).
enum Column { kFeatures = 0, kPoses = 1, kObservations = 2, kIterations = 9, kChi2PerDof = 14,
              kTermination = 15 };

class BenchmarkCommandTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("graphslam_benchmark_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::vector<std::string> Args(const fs::path& out) const {
    // One run and the pose-graph start: on these small GPS campuses the
    // default start ends in a local minimum (docs/benchmarks.md,
    // "`graphslam benchmark` with default options"), and two runs of 50-100 poses are barely tied.
    return {"benchmark", "-o", out.string(), "--features", "1e4,2e4", "--runs", "1",
            "--initialization", "pose-graph", "-q"};
  }
  fs::path dir_;
};

TEST_F(BenchmarkCommandTest, EverySizeIsSolvedToConvergenceAndReported) {
  const fs::path out = dir_ / "sweep";
  ASSERT_EQ(RunGraphslam(Args(out)), 0);
  const auto rows = Rows(out / "scaling.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[0][kFeatures], "10000");
  EXPECT_EQ(rows[0][kPoses], "100");
  EXPECT_EQ(rows[1][kFeatures], "20000");
  EXPECT_EQ(rows[1][kPoses], "200");
  for (const auto& row : rows) {
    ASSERT_EQ(row.size(), 16u);
    EXPECT_GT(std::stoll(row[kObservations]), 0);
    EXPECT_GT(std::stoi(row[kIterations]), 0);
    EXPECT_NE(row[kTermination], "max_iterations");
    const double chi2_per_dof = std::stod(row[kChi2PerDof]);
    EXPECT_GT(chi2_per_dof, 0.8) << "features " << row[kFeatures];
    EXPECT_LT(chi2_per_dof, 1.2) << "features " << row[kFeatures];
  }
  const std::string html = Read(out / "scaling.html");
  EXPECT_NE(html.find("Fitted exponents"), std::string::npos);
  for (const char* plot : {"end-to-end seconds", "seconds per iteration", "peak RSS", "store bytes"})
    EXPECT_NE(html.find(std::string("<figure data-quantity=\"") + plot + "\"><svg"),
              std::string::npos)
        << plot;
  // The stores are removed once a size is done; the steps' logs stay.
  EXPECT_FALSE(fs::exists(out / ".benchmark" / "n10000" / "store"));
  EXPECT_TRUE(fs::exists(out / ".benchmark" / "n10000" / "solve.log"));

  // Killed after the first size, then resumed: the first row is kept as it
  // was, the second is computed, and the deterministic columns equal the
  // uninterrupted sweep's.
  const fs::path resumed = dir_ / "resumed";
  ASSERT_TRUE(graphslam::testing::SpawnAndKillAtStopPoint(Args(resumed), "benchmark_size_done 10000"));
  const auto at_kill = Rows(resumed / "scaling.csv");
  ASSERT_EQ(at_kill.size(), 1u);
  std::vector<std::string> args = Args(resumed);
  args.push_back("--resume");
  ASSERT_EQ(RunGraphslam(args), 0);
  const auto after = Rows(resumed / "scaling.csv");
  ASSERT_EQ(after.size(), 2u);
  EXPECT_EQ(after[0], at_kill[0]);
  for (size_t r = 0; r < 2; ++r)
    for (const int column : {kFeatures, kPoses, kObservations, kIterations, kChi2PerDof,
                             kTermination})
      EXPECT_EQ(after[r][column], rows[r][column]) << "row " << r << " column " << column;
}

TEST_F(BenchmarkCommandTest, ForeignFolderAndBadSizesAreRefused) {
  const fs::path out = dir_ / "mine";
  fs::create_directories(out);
  std::ofstream(out / "thesis.tex") << "keep me";
  EXPECT_EQ(RunGraphslam(Args(out)), 2);
  EXPECT_EQ(Read(out / "thesis.tex"), "keep me");
  EXPECT_FALSE(fs::exists(out / ".benchmark"));
  EXPECT_EQ(RunGraphslam({"benchmark", "-o", (dir_ / "x").string(), "--features", "1e4,abc"}), 1);
  EXPECT_EQ(RunGraphslam({"benchmark", "-o", (dir_ / "x").string(), "--features", "12.5"}), 1);
}

}  // namespace
