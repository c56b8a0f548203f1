// The job file's solver.model_tolerance: its default is the solver's (as are
// the other stopping rules'), and a value given is read.
#include <gtest/gtest.h>

#include <string>

#include "core/graphslam_solver.h"
#include "tools/job/job_spec.h"

namespace graphslam::tools::job {
namespace {

const std::string kRuns =
    "output: out/\n"
    "runs:\n"
    "  - {name: robot1, format: mrclam, path: data/MRCLAM_Dataset1, robot: 1}\n";

TEST(JobModelTolerance, DefaultIsTheSolversDefault) {
  StatusOr<JobSpec> job = ParseJobSpec(kRuns, "/jobs/j.yaml");
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_EQ(job->solver.model_tolerance, core::SolverOptions().model_tolerance);
  EXPECT_EQ(job->solver.function_tolerance, core::SolverOptions().function_tolerance);
  EXPECT_EQ(job->solver.max_iterations, core::SolverOptions().max_iterations);
}

TEST(JobModelTolerance, AGivenValueIsRead) {
  StatusOr<JobSpec> job =
      ParseJobSpec(kRuns + "solver: {model_tolerance: 0}\n", "/jobs/j.yaml");
  ASSERT_TRUE(job.ok()) << job.status().ToString();
  EXPECT_EQ(job->solver.model_tolerance, 0.0);
  StatusOr<JobSpec> bad =
      ParseJobSpec(kRuns + "solver: {model_tolerance: often}\n", "/jobs/j.yaml");
  EXPECT_FALSE(bad.ok());
}

}  // namespace
}  // namespace graphslam::tools::job
