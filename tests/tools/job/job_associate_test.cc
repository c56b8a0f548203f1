// The associate stage with unknown correspondences: a simulated campus
// driven twice with its landmark ids dropped (ids: false) and no GPS. Each run
// alone is its own component; data association (partition/association/association_driver.h)
// across the runs merges their landmarks and ties them into one component,
// whose trajectories match the ground truth within the noise. Without the
// associate stage the same job leaves the runs apart (reported, not merged).
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tools/campus_simulator.h"
#include "tests/tools/job/job_test_folder.h"
#include "tools/job/job_runner.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;

using JobAssociate = JobTestFolder;

// Both runs start at their true first pose (a known start), so the merged
// landmarks are the only tie between them.
constexpr const char* kRuns =
    "runs:\n"
    "  - name: campus\n"
    "    format: simulate\n"
    "    ids: false\n"
    "    simulate: {poses: 300, runs: 2, seed: 3, initial_position_sigma: 0,\n"
    "               initial_heading_sigma: 0}\n";

TEST_F(JobAssociate, RunsWithoutIdsAreTiedByDataAssociation) {
  const Status status = Run(std::string("output: out\nthreads: 2\n") + kRuns);
  ASSERT_TRUE(status.ok()) << status.ToString();
  const nlohmann::json report = ReadJsonFile(dir_ / "out" / "report.json");
  ASSERT_TRUE(report.contains("association")) << report.dump(1);
  const nlohmann::json& a = report["association"];
  EXPECT_EQ(a["components_before"].get<int>(), 2);
  EXPECT_EQ(a["components_after"].get<int>(), 1);
  // One feature per observation before; about the observed landmarks after.
  CampusSimulatorOptions options;
  options.poses = 300;
  options.runs = 2;
  options.seed = 3;
  StatusOr<SimulatedCampus> campus = SimulateCampus(options);
  ASSERT_TRUE(campus.ok());
  EXPECT_EQ(a["initial_features"].get<int64_t>(),
            static_cast<int64_t>(campus->problem.observations.size()));
  EXPECT_GE(a["final_features"].get<int64_t>(), campus->observed_features);
  EXPECT_LE(a["final_features"].get<int64_t>(), campus->observed_features * 5 / 4);
  ASSERT_EQ(report["runs"].size(), 2u);
  for (const nlohmann::json& run : report["runs"]) {
    EXPECT_EQ(run["component"].get<int>(), 0) << run.dump();
    EXPECT_TRUE(run["tied"].get<bool>()) << run.dump();
    // Range 0.1 m / bearing 0.02 rad noise, no GPS: decimetres.
    EXPECT_LT(run["position_rmse_m"].get<double>(), 0.5) << run.dump();
  }
  EXPECT_TRUE(report["warnings"].empty()) << report["warnings"].dump();
  ASSERT_EQ(report["components"].size(), 1u);
}

TEST_F(JobAssociate, WithoutTheAssociateStageTheRunsStayApart) {
  const Status status = Run(std::string("output: out\nthreads: 2\n"
                                        "stages: [ingest, initialize, optimize, export]\n") +
                            kRuns);
  ASSERT_TRUE(status.ok()) << status.ToString();
  const nlohmann::json report = ReadJsonFile(dir_ / "out" / "report.json");
  EXPECT_FALSE(report.contains("association"));
  EXPECT_EQ(report["components"].size(), 2u);
  for (const nlohmann::json& run : report["runs"]) EXPECT_FALSE(run["tied"].get<bool>());
  EXPECT_EQ(report["warnings"].size(), 2u) << report["warnings"].dump();
}

}  // namespace
}  // namespace graphslam::tools::job
