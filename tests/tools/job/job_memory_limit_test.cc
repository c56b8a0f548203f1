// The job's memory_limit (tools/job/job_memory_budget.h): the budget's terms,
// the refusal of a limit below the need before the job writes anything, and
// a job at exactly the named need running to its outputs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <regex>
#include <string>

#include "tests/tools/job/job_test_folder.h"
#include "tools/exit_codes.h"
#include "tools/job/job_memory_budget.h"
#include "tools/memory_budget.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

constexpr int64_t kMiB = int64_t{1} << 20;

TEST(JobMemoryBudget, CoreIsTheSumOfItsTermsAndTheNeedIsTheSmallestLimit) {
  const JobSize size{10'000, 2'000, 50'000, false, false, false};
  const int64_t core = kJobBaseBytes + 10'000 * kJobBytesPerPose + 50'000 * kJobBytesPerObservation +
                       2'000 * kJobBytesPerFeature;
  const StatusOr<JobBudget> at_need = BudgetJob(core, size);
  ASSERT_TRUE(at_need.ok()) << at_need.status().ToString();
  EXPECT_EQ(at_need->need_bytes, core);
  EXPECT_EQ(at_need->core_bytes, core);
  EXPECT_EQ(at_need->spare_bytes, 0);
  const StatusOr<JobBudget> below = BudgetJob(core - 1, size);
  ASSERT_FALSE(below.ok());
  EXPECT_TRUE(below.status().IsInvalidArgument());
  EXPECT_EQ(ExitCodeFor(below.status()), kExitBadInput);
  const std::string bytes = std::to_string(core) + " bytes)";
  EXPECT_THAT(below.status().message(), HasSubstr(bytes));
  EXPECT_THAT(below.status().message(), HasSubstr("10000 poses"));
  EXPECT_THAT(below.status().message(), HasSubstr("50000 observations"));
  // A second problem (compare_without_gps) doubles the per-item terms.
  const StatusOr<JobBudget> twice = BudgetJob(int64_t{1} << 30, JobSize{10'000, 2'000, 50'000,
                                                                         false, true, false});
  ASSERT_TRUE(twice.ok());
  EXPECT_EQ(twice->core_bytes - kJobBaseBytes, 2 * (core - kJobBaseBytes));
}

TEST(JobMemoryBudget, TheMapsPartsAddUpToTheLimitAndTheTilesKeepTheirLeast) {
  const JobSize size{600, 95, 2'158, true, false, false};
  const int64_t core = kJobBaseBytes + 600 * kJobBytesPerPose + 2'158 * kJobBytesPerObservation +
                       95 * kJobBytesPerFeature;
  const int64_t need = core + kJobMapFixedBytes + 20'000 * kJobMapBytesPerBatchPoint + kJobMinTileBytes;
  const StatusOr<JobBudget> at_need = BudgetJob(need, size);
  ASSERT_TRUE(at_need.ok()) << at_need.status().ToString();
  EXPECT_EQ(at_need->need_bytes, need);
  EXPECT_FALSE(BudgetJob(need - 1, size).ok());
  EXPECT_THAT(BudgetJob(need - 1, size).status().message(), HasSubstr("the map stage adds"));
  for (const int64_t limit : {need, need + kMiB, 64 * kMiB, 200 * kMiB, int64_t{8} << 30}) {
    const StatusOr<JobBudget> budget = BudgetJob(limit, size);
    ASSERT_TRUE(budget.ok()) << limit;
    EXPECT_GE(budget->map_tile_bytes, kJobMinTileBytes) << limit;
    EXPECT_GE(budget->map_batch_points, 20'000) << limit;
    EXPECT_LE(budget->map_batch_points, 2'000'000) << limit;
    EXPECT_LE(budget->map_batch_points, std::max<int64_t>(limit / 2048, 20'000)) << limit;
    // The map stage's parts fill the limit exactly: nothing beyond it.
    EXPECT_EQ(core + kJobMapFixedBytes + budget->map_batch_points * kJobMapBytesPerBatchPoint +
                  budget->map_tile_bytes,
              limit)
        << limit;
  }
  // Without scans no map term.
  EXPECT_EQ(BudgetJob(core, JobSize{600, 95, 2'158, false, false, false})->need_bytes, core);
}

TEST(JobMemoryBudget, DataAssociationAddsItsPerFeatureTerm) {
  const JobSize known{1'000, 3'507, 3'507, false, false, false};
  JobSize unknown = known;
  unknown.associate = true;
  const int64_t core = BudgetJob(int64_t{1} << 30, known)->need_bytes;
  EXPECT_EQ(BudgetJob(int64_t{1} << 30, unknown)->need_bytes,
            core + 3'507 * kJobAssociateBytesPerFeature);
  EXPECT_THAT(BudgetJob(core, unknown).status().message(),
              HasSubstr("data association (ids: false) adds"));
}

TEST(JobMemoryBudget, CholmodFactorFitsInWhatTheLimitLeavesOrNamesTheLimitThatHoldsIt) {
  const JobSize size{1'000, 100, 4'000, false, false, false};
  const int64_t core = BudgetJob(int64_t{1} << 30, size)->core_bytes;
  const double factor = 3.0 * kMiB;  // 8 lnz
  EXPECT_TRUE(CheckJobCholmodFactor(core + 4 * 3 * kMiB, size, factor).ok());
  const Status refused = CheckJobCholmodFactor(core + 4 * 3 * kMiB - 1, size, factor);
  ASSERT_FALSE(refused.ok());
  EXPECT_TRUE(refused.IsInvalidArgument());
  const std::string smallest = std::to_string(core + kCholmodBytesPerFactorByte * 3 * kMiB);
  EXPECT_THAT(refused.message(), HasSubstr(smallest + " bytes): the smallest limit that works"));
}

using JobMemoryLimit = JobTestFolder;

constexpr const char* kRuns =
    "runs:\n"
    "  - name: campus\n"
    "    format: simulate\n"
    "    simulate: {poses: 400, runs: 2, gps_every: 10, seed: 4}\n";

// The need the refusal names, in bytes.
int64_t NamedNeed(const Status& status) {
  std::smatch match;
  const std::string message = status.message();
  if (!std::regex_search(message, match, std::regex("need of [0-9.]+ [MG]iB \\(([0-9]+) bytes\\)")))
    return -1;
  return std::atoll(match[1].str().c_str());
}

TEST_F(JobMemoryLimit, ATooSmallLimitIsRefusedBeforeAnythingIsWrittenAndTheNamedNeedRuns) {
  const Status refused = Run("output: out\nthreads: 2\nmemory_limit: 20MiB\n" + std::string(kRuns));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(ExitCodeFor(refused), kExitBadInput);
  EXPECT_THAT(refused.message(), HasSubstr("job.yaml: memory_limit 20.0 MiB is below"));
  EXPECT_THAT(refused.message(), HasSubstr("400 poses"));
  EXPECT_FALSE(fs::exists(dir_ / "out"));  // not even the output folder

  const int64_t need = NamedNeed(refused);
  ASSERT_GT(need, 20 * kMiB) << refused.ToString();
  // One byte less is refused too: the named need is the smallest limit.
  EXPECT_FALSE(Run("output: out\nthreads: 2\nmemory_limit: " + std::to_string(need - 1) + "\n" +
                   kRuns)
                   .ok());
  EXPECT_FALSE(fs::exists(dir_ / "out"));

  const Status status =
      Run("output: out\nthreads: 2\nmemory_limit: " + std::to_string(need) + "\n" + kRuns);
  ASSERT_TRUE(status.ok()) << status.ToString();
  for (const char* file : {"trajectories/campus_1.tum", "graph.g2o", "report.json"})
    EXPECT_TRUE(fs::exists(dir_ / "out" / file)) << file;
  const nlohmann::json report = ReadJsonFile(dir_ / "out" / "report.json");
  EXPECT_EQ(report["memory_limit_bytes"].get<int64_t>(), need);
  // At the need nothing is left beside the problem: no CHOLMOD factor.
  EXPECT_EQ(report["components"][0]["linear_solver"].get<std::string>(), "pcg");
}

}  // namespace
}  // namespace graphslam::tools::job
