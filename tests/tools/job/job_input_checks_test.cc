// Issue 22, defects 5 and 7 for jobs: a key given twice in a job file and a
// run name that cannot be a file name are errors when the job file is read
// (naming the key / name and the line), not after the job ran; an edited
// file of OUTPUT/.job/ (a stage result or state.json itself) stops
// `run --resume` with Corruption naming the file instead of resuming to a
// different output.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/tools/job/job_test_folder.h"
#include "tools/job/job_spec.h"

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(JobSpecChecks, DuplicateKeysAreErrorsNamingKeyAndLine) {
  StatusOr<JobSpec> top = ParseJobSpec(
      "output: a\nruns:\n  - {name: r, format: g2o, path: x.g2o}\noutput: b\n", "/j/job.yaml");
  ASSERT_FALSE(top.ok());
  EXPECT_EQ(top.status().message(),
            "/j/job.yaml:4:1: duplicate key 'output' (first at line 1); expected each key once "
            "per mapping");
  StatusOr<JobSpec> nested = ParseJobSpec(
      "output: a\nsolver:\n  max_iterations: 5\n  max_iterations: 50\n"
      "runs:\n  - {name: r, format: g2o, path: x.g2o}\n",
      "/j/job.yaml");
  ASSERT_FALSE(nested.ok());
  EXPECT_EQ(nested.status().message(),
            "/j/job.yaml:4:3: duplicate key 'max_iterations' (first at line 3); expected each "
            "key once per mapping");
  StatusOr<JobSpec> in_run = ParseJobSpec(
      "output: a\nruns:\n  - {name: r, format: g2o, path: x.g2o, name: s}\n", "/j/job.yaml");
  ASSERT_FALSE(in_run.ok());
  EXPECT_THAT(in_run.status().message(), HasSubstr("/j/job.yaml:3:"));
  EXPECT_THAT(in_run.status().message(), HasSubstr("duplicate key 'name'"));
}

TEST(JobSpecChecks, RunNameTooLongForAFileNameIsRejectedWhenRead) {
  const std::string name(10 << 20, 'a');  // 10 MB, as in the issue
  StatusOr<JobSpec> job = ParseJobSpec(
      "output: a\nruns:\n  - {format: g2o, path: x.g2o,\n     name: " + name + "}\n", "/j/job.yaml");
  ASSERT_FALSE(job.ok());
  EXPECT_TRUE(job.status().IsInvalidArgument());
  EXPECT_THAT(job.status().message(), HasSubstr("/j/job.yaml:4:12: run name 'aaaa"));
  EXPECT_THAT(job.status().message(),
              HasSubstr("is 10485760 bytes long; expected at most 128 (it names files such as "
                        "trajectories/<name>.tum)"));
  EXPECT_LT(job.status().message().size(), 300u);  // the name is not echoed whole
  // 128 bytes: a file name.
  std::string longest_name = "output: a\nruns:\n  - {format: g2o, path: x.g2o, name: ";
  longest_name.append(128, 'b').append("}\n");
  EXPECT_TRUE(ParseJobSpec(longest_name, "/j/job.yaml").ok());
  StatusOr<JobSpec> slash =
      ParseJobSpec("output: a\nruns:\n  - {format: g2o, path: x.g2o, name: a/b}\n", "/j/job.yaml");
  ASSERT_FALSE(slash.ok());
  EXPECT_THAT(slash.status().message(), HasSubstr("run name 'a/b' is not a plain file name"));
}

class JobStateIntegrity : public JobTestFolder {
 protected:
  static constexpr const char* kJob =
      "output: out\n"
      "solver: {max_iterations: 10, initialization: odometry}\n"
      "runs:\n"
      "  - {name: sim, format: simulate, simulate: {poses: 200, seed: 3}}\n";
  Status Resume() {
    RunJobOptions options;
    options.job_path = (dir_ / "job.yaml").string();
    options.quiet = true;
    options.resume = true;
    return RunJob(options);
  }
  fs::path Work() const { return dir_ / "out" / ".job"; }
};

TEST_F(JobStateIntegrity, AnEditedStageResultStopsTheResume) {
  ASSERT_TRUE(Run(kJob).ok());
  ASSERT_TRUE(Resume().ok());  // untouched: every stage is skipped
  // One digit of the initialized guess changed: same size, other bytes.
  const fs::path file = Work() / "initialized.graphslam";
  const std::string original = ReadFile(file);
  std::string text = original;
  const size_t pose = text.find("\nPOSE 5 ");
  ASSERT_NE(pose, std::string::npos);
  const size_t digit = text.find_first_of("123456789", pose + 8);
  ASSERT_NE(digit, std::string::npos);
  text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);
  std::ofstream(file, std::ios::binary) << text;
  const Status status = Resume();
  ASSERT_FALSE(status.ok());
  EXPECT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(file.string() + ": changed after the stage that "
                                                          "wrote it completed"));
  EXPECT_THAT(status.message(), HasSubstr("run without --resume to start over"));
  // A deleted stage result too.
  std::ofstream(file, std::ios::binary) << original;
  ASSERT_TRUE(Resume().ok());
  fs::remove(Work() / "runs.json");
  EXPECT_THAT(Resume().message(), HasSubstr("runs.json: missing"));
}

TEST_F(JobStateIntegrity, AnEditedStateFileStopsTheResume) {
  ASSERT_TRUE(Run(kJob).ok());
  const fs::path state = Work() / "state.json";
  std::string text = ReadFile(state);
  // "optimize" no longer completed: the resume would re-run it silently.
  const size_t at = text.find("\"optimize\"");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 10, "\"optimizd\"");
  std::ofstream(state, std::ios::binary) << text;
  const Status status = Resume();
  ASSERT_FALSE(status.ok());
  EXPECT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr(state.string() + ": checksum mismatch"));
}

}  // namespace
}  // namespace graphslam::tools::job
