// Job files: what a valid one means, and that every mistake is reported with
// the job file's line and column.
#include "tools/job/job_spec.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace graphslam::tools::job {
namespace {

using ::testing::HasSubstr;

TEST(JobSpec, MinimalMrclamExampleOfTheIssue) {
  const std::string text =
      "output: out/\n"
      "runs:\n"
      "  - {name: robot1, format: mrclam, path: data/MRCLAM_Dataset1, robot: 1}\n"
      "  - {name: robot2, format: mrclam, path: data/MRCLAM_Dataset1, robot: 2}\n";
  StatusOr<JobSpec> job = ParseJobSpec(text, "/jobs/j.yaml");
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_EQ(job->output, "/jobs/out/");
  ASSERT_EQ(job->runs.size(), 2u);
  EXPECT_EQ(job->runs[0].name, "robot1");
  EXPECT_EQ(job->runs[1].robot, 2);
  EXPECT_EQ(job->runs[1].path, "/jobs/data/MRCLAM_Dataset1");
  EXPECT_EQ(job->runs[1].line, 4);
  // Default: every stage, in order.
  ASSERT_EQ(job->stages.size(), kAllStages.size());
  EXPECT_EQ(job->stages.front(), Stage::kIngest);
  EXPECT_EQ(job->stages.back(), Stage::kExport);
  EXPECT_EQ(job->threads, 0);
  EXPECT_EQ(job->memory_limit, 0);
}

TEST(JobSpec, AllSettings) {
  const std::string text =
      "output: /abs/out\n"
      "threads: 3\n"
      "memory_limit: 1.5GiB\n"
      "stages: [export, ingest, optimize]\n"
      "compare_without_gps: true\n"
      "solver: {max_iterations: 7, robust_kernel: 'cauchy:1', initialization: odometry}\n"
      "runs:\n"
      "  - name: sim\n"
      "    format: simulate\n"
      "    simulate: {poses: 300, runs: 2, gps_every: 5, seed: 9, gps_denied_region: [0, 0, 50, 40]}\n"
      "  - name: g\n"
      "    format: g2o\n"
      "    path: a.g2o\n"
      "    gps: {path: fixes.csv, frame: enu, sigma: 0.5}\n"
      "    ground_truth: gt.tum\n";
  StatusOr<JobSpec> job = ParseJobSpec(text, "j.yaml");
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_EQ(job->output, "/abs/out");
  EXPECT_EQ(job->threads, 3);
  EXPECT_EQ(job->memory_limit, static_cast<int64_t>(1.5 * 1024 * 1024 * 1024));
  ASSERT_EQ(job->stages.size(), 3u);  // execution order, not file order
  EXPECT_EQ(job->stages[0], Stage::kIngest);
  EXPECT_EQ(job->stages[1], Stage::kOptimize);
  EXPECT_EQ(job->stages[2], Stage::kExport);
  EXPECT_TRUE(job->compare_without_gps);
  EXPECT_EQ(job->solver.max_iterations, 7);
  EXPECT_EQ(job->solver.robust_kernel, "cauchy:1");
  EXPECT_EQ(job->solver.initialization, "odometry");
  EXPECT_EQ(job->runs[0].simulate.poses, 300);
  EXPECT_EQ(job->runs[0].simulate.runs, 2);
  EXPECT_EQ(job->runs[0].simulate.gps_every, 5);
  EXPECT_EQ(job->runs[0].simulate.seed, 9u);
  ASSERT_TRUE(job->runs[0].gps_denied_region.has_value());
  EXPECT_DOUBLE_EQ((*job->runs[0].gps_denied_region)[2], 50.0);
  ASSERT_TRUE(job->runs[1].gps.has_value());
  EXPECT_EQ(job->runs[1].gps->frame, "enu");
  EXPECT_DOUBLE_EQ(job->runs[1].gps->sigma, 0.5);
  EXPECT_THAT(job->runs[1].ground_truth, HasSubstr("gt.tum"));
}

TEST(JobSpec, MapScansAndIds) {
  const std::string text =
      "output: o\n"
      "map: {resolution: 0.1, max_range: 40, pcd_voxel: 0.3, sensor_height: 2}\n"
      "runs:\n"
      "  - name: sim\n"
      "    format: simulate\n"
      "    ids: false\n"
      "    simulate: {scans: true, scan_beams: 45, scan_max_range: 20, scan_range_sigma: 0.05,\n"
      "               initial_position_sigma: 0, initial_heading_sigma: 0}\n"
      "  - {name: g, format: g2o, path: a.g2o, scans: scan_folder}\n";
  StatusOr<JobSpec> job = ParseJobSpec(text, "/jobs/j.yaml");
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_DOUBLE_EQ(job->map.resolution, 0.1);
  EXPECT_DOUBLE_EQ(job->map.max_range, 40.0);
  EXPECT_DOUBLE_EQ(job->map.pcd_voxel, 0.3);
  EXPECT_DOUBLE_EQ(job->map.sensor_height, 2.0);
  EXPECT_FALSE(job->runs[0].ids);
  EXPECT_TRUE(job->runs[0].simulate_scans.enabled);
  EXPECT_EQ(job->runs[0].simulate_scans.beams, 45);
  EXPECT_DOUBLE_EQ(job->runs[0].simulate_scans.max_range, 20.0);
  EXPECT_DOUBLE_EQ(job->runs[0].simulate_scans.range_sigma, 0.05);
  EXPECT_DOUBLE_EQ(job->runs[0].simulate.initial_position_sigma, 0.0);
  EXPECT_TRUE(job->runs[1].ids);
  EXPECT_FALSE(job->runs[1].simulate_scans.enabled);
  EXPECT_EQ(job->runs[1].scans, "/jobs/scan_folder");
  // Defaults.
  StatusOr<JobSpec> plain = ParseJobSpec("output: o\nruns:\n  - {name: s, format: simulate}\n", "j.yaml");
  ASSERT_TRUE(plain.ok());
  EXPECT_DOUBLE_EQ(plain->map.resolution, 0.2);
  EXPECT_FALSE(plain->runs[0].simulate_scans.enabled);
  EXPECT_TRUE(plain->runs[0].ids);
}

TEST(JobSpec, GroundTruthFilesAndInformationRepair) {
  const std::string text =
      "output: o\n"
      "solver: {repair_information: true}\n"
      "runs:\n"
      "  - {name: a, format: g2o, path: a.g2o, ground_truth: a.tum}\n"
      "  - {name: b, format: g2o, path: b.g2o,\n"
      "     ground_truth: {path: poses/00.txt, format: kitti, times: seq/times.txt}}\n";
  StatusOr<JobSpec> job = ParseJobSpec(text, "/jobs/j.yaml");
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_TRUE(job->solver.repair_information);
  EXPECT_EQ(job->runs[0].ground_truth, "/jobs/a.tum");
  EXPECT_EQ(job->runs[0].ground_truth_format, "auto");
  EXPECT_EQ(job->runs[1].ground_truth, "/jobs/poses/00.txt");
  EXPECT_EQ(job->runs[1].ground_truth_format, "kitti");
  EXPECT_EQ(job->runs[1].ground_truth_times, "/jobs/seq/times.txt");
  StatusOr<JobSpec> plain = ParseJobSpec("output: o\nruns:\n  - {name: s, format: simulate}\n", "j.yaml");
  ASSERT_TRUE(plain.ok());
  EXPECT_FALSE(plain->solver.repair_information);
}

struct BadCase {
  std::string text;
  std::string location;  // "j.yaml:<line>:<column>"
  std::string message;
};

class JobSpecErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(JobSpecErrors, NameTheFileLineAndColumn) {
  StatusOr<JobSpec> job = ParseJobSpec(GetParam().text, "j.yaml");
  ASSERT_FALSE(job.ok());
  EXPECT_TRUE(job.status().IsInvalidArgument()) << job.status().ToString();
  EXPECT_THAT(job.status().message(), HasSubstr(GetParam().location + ": "));
  EXPECT_THAT(job.status().message(), HasSubstr(GetParam().message));
}

INSTANTIATE_TEST_SUITE_P(
    Cases, JobSpecErrors,
    ::testing::Values(
        BadCase{"output: o\nruns:\n  - {name: a, format: g2o, path: x.g2o, colour: red}\n",
                "j.yaml:3:41", "unknown key 'colour'"},
        BadCase{"output: o\nruns:\n  - {name: a, format: gpx, path: x}\n", "j.yaml:3:23",
                "expected g2o, isam, mrclam, native or simulate"},
        BadCase{"output: o\nruns:\n  - {format: g2o, path: x}\n", "j.yaml:3:5", "no 'name'"},
        BadCase{"output: o\nthreads: many\nruns:\n  - {name: a, format: g2o, path: x}\n",
                "j.yaml:2:10", "expected an integer"},
        BadCase{"output: o\nruns: [\n", "j.yaml:3:1", "not valid YAML"},
        BadCase{"output: o\nruns: []\n", "j.yaml:2:7", "non-empty list"},
        BadCase{"output: o\nstages: [ingest, polish]\nruns:\n  - {name: a, format: g2o, path: x}\n",
                "j.yaml:2:18", "unknown stage 'polish'"},
        BadCase{"output: o\nruns:\n  - {name: a, format: g2o, path: x}\n  - {name: a, format: g2o, path: y}\n",
                "j.yaml:4:12", "duplicate run name 'a'"},
        BadCase{"output: o\nruns:\n  - {name: a, format: g2o}\n", "j.yaml:3:5", "no 'path'"},
        BadCase{"output: o\nruns:\n  - {name: a, format: g2o, path: x, robot: 2}\n", "j.yaml:3:44",
                "'robot' is for format: mrclam only"},
        BadCase{"output: o\nruns:\n  - {name: a, format: mrclam, path: x, robot: 9}\n", "j.yaml:3:47",
                "expected an integer in [1, 5]"},
        BadCase{"output: o\nruns:\n  - {name: ../a, format: g2o, path: x}\n", "j.yaml:3:12",
                "not a plain file name"},
        BadCase{"output: o\nmemory_limit: lots\nruns:\n  - {name: a, format: g2o, path: x}\n",
                "j.yaml:2:15", "expected a size"},
        BadCase{"output: o\nruns:\n  - {name: s, format: simulate, simulate: {poses: 1}}\n",
                "j.yaml:3:51", "expected an integer in [2,"},
        BadCase{"output: o\nruns:\n  - {name: s, format: simulate, simulate: {gps_denied_region: [1, 2]}}\n",
                "j.yaml:3:63", "[x0, y0, x1, y1]"},
        BadCase{"- just\n- a list\n", "j.yaml:1:1", "a job file is a mapping"},
        BadCase{"output: o\nmap: {resolution: -1}\nruns:\n  - {name: s, format: simulate}\n",
                "j.yaml:2:19", "map resolution must be > 0"},
        BadCase{"output: o\nmap: {colour: red}\nruns:\n  - {name: s, format: simulate}\n",
                "j.yaml:2:7", "unknown key 'colour'"},
        BadCase{"output: o\nruns:\n  - {name: s, format: simulate, simulate: {scans: maybe}}\n",
                "j.yaml:3:51", "expected true or false"},
        BadCase{"output: o\nruns:\n  - {name: s, format: simulate, simulate: {scan_max_range: 0}}\n",
                "j.yaml:3:60", "'scan_max_range' must be > 0"},
        BadCase{"output: o\nruns:\n  - {name: s, format: simulate, ids: perhaps}\n",
                "j.yaml:3:38", "expected true or false"},
        BadCase{"output: o\nruns:\n  - {name: a, format: g2o, path: x, ground_truth: {path: g, format: gpx}}\n", "j.yaml:3:69",
                "ground_truth format 'gpx'; expected auto, tum or kitti"},
        BadCase{"output: o\nruns:\n  - {name: a, format: g2o, path: x, ground_truth: {format: kitti}}\n", "j.yaml:3:51",
                "ground_truth has no 'path'"},
        BadCase{"output: o\nsolver: {repair_information: sometimes}\nruns:\n  - {name: s, format: simulate}\n",
                "j.yaml:2:30", "expected true or false"}));

TEST(JobSpec, MissingFileIsNotFound) {
  StatusOr<JobSpec> job = ReadJobSpec("/nonexistent/job.yaml");
  ASSERT_FALSE(job.ok());
  EXPECT_TRUE(job.status().IsNotFound());
}

}  // namespace
}  // namespace graphslam::tools::job
