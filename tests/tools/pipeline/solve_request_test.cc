// The application layer's request (tools/pipeline/solve_request.h): command
// options and job settings become one validated SolveRequest, or a usage
// error that names the option, before anything is read.
#include "tools/pipeline/solve_request.h"

#include <gtest/gtest.h>

#include <string>

#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

SolveCommandOptions Options() {
  SolveCommandOptions options;
  options.input = "in.g2o";  // not read: requests are built before any I/O
  return options;
}

// The error's message for `options`, "" when the request is valid.
std::string ErrorFor(const SolveCommandOptions& options) {
  StatusOr<SolveRequest> request = MakeSolveRequest(options);
  if (request.ok()) return "";
  EXPECT_TRUE(request.status().IsInvalidArgument()) << request.status().ToString();
  return request.status().message();
}

bool StartsWith(const std::string& text, const std::string& prefix) {
  return text.rfind(prefix, 0) == 0;
}

TEST(SolveRequest, DefaultsBecomeTheCommandLinesSolverOptions) {
  SolveCommandOptions options = Options();
  options.output_g2o = "out.g2o";
  options.report = "report.json";
  StatusOr<SolveRequest> request = MakeSolveRequest(options);
  ASSERT_TRUE(request.ok()) << request.status().ToString();
  EXPECT_FALSE(request->format.has_value());  // auto: detected from the content
  EXPECT_EQ(request->initialization, Initialization::kAuto);
  EXPECT_EQ(request->memory_limit_bytes, 0);
  EXPECT_EQ(request->outputs.g2o, "out.g2o");
  EXPECT_EQ(request->outputs.report, "report.json");
  EXPECT_TRUE(request->outputs.tum.empty());
  const core::SolverOptions& solver = request->solver;
  EXPECT_EQ(solver.linear_solver, core::LinearSolverType::kAuto);
  EXPECT_EQ(solver.preconditioner, core::PreconditionerType::kSubgraph);
  EXPECT_EQ(solver.max_iterations, 100);
  EXPECT_EQ(solver.function_tolerance, 1e-6);
  // The command line's 0: the radius is chosen by the linear solver.
  EXPECT_EQ(solver.initial_trust_region_radius, 0.0);
  EXPECT_EQ(solver.max_eliminated_observations, 64);
  EXPECT_TRUE(solver.fused_chunk_pass);
  EXPECT_EQ(solver.observation_kernel.type, core::RobustKernel::Type::kNone);
}

TEST(SolveRequest, EverySolverValueReachesTheSolverOptions) {
  SolveCommandOptions options = Options();
  options.solver = "pcg";
  options.preconditioner = "block-jacobi";
  options.pcg_eta_min = 1e-6;  // the 3-D solve used to drop it
  options.pcg_eta_max = 0.05;
  options.pcg_deflation = 8;
  options.pcg_truncation = 0.2;
  options.max_iterations = 7;
  options.function_tolerance = 1e-4;
  options.initial_trust_region_radius = 123.0;
  options.max_eliminated_observations = 5;
  options.two_pass = true;
  options.robust_kernel = "cauchy:2 odometry=huber:3";
  options.format = "toro";
  options.initialization = "pose-graph";
  options.memory_limit = "2G";
  StatusOr<SolveRequest> request = MakeSolveRequest(options);
  ASSERT_TRUE(request.ok()) << request.status().ToString();
  const core::SolverOptions& solver = request->solver;
  EXPECT_EQ(solver.linear_solver, core::LinearSolverType::kPcg);
  EXPECT_EQ(solver.preconditioner, core::PreconditionerType::kBlockJacobi);
  EXPECT_EQ(solver.pcg_relative_tolerance, 1e-6);
  EXPECT_EQ(solver.pcg_eta_max, 0.05);
  EXPECT_EQ(solver.pcg_deflation_poses, 8);
  EXPECT_EQ(solver.pcg_truncation, 0.2);
  EXPECT_EQ(solver.max_iterations, 7);
  EXPECT_EQ(solver.function_tolerance, 1e-4);
  EXPECT_EQ(solver.initial_trust_region_radius, 123.0);
  EXPECT_EQ(solver.max_eliminated_observations, 5);
  EXPECT_FALSE(solver.fused_chunk_pass);
  EXPECT_EQ(solver.observation_kernel.type, core::RobustKernel::Type::kCauchy);
  EXPECT_EQ(solver.observation_kernel.scale, 2.0);
  EXPECT_EQ(solver.pose_kernels.relative_pose.type, core::RobustKernel::Type::kHuber);
  EXPECT_EQ(solver.pose_kernels.relative_pose.scale, 3.0);
  ASSERT_TRUE(request->format.has_value());
  EXPECT_EQ(*request->format, storage::InputFormat::kToro);
  EXPECT_EQ(request->initialization, Initialization::kPoseGraph);
  EXPECT_EQ(request->memory_limit_bytes, int64_t{2} << 30);
}

TEST(SolveRequest, NamesTheOptionThatDoesNotParse) {
  SolveCommandOptions options = Options();
  options.format = "xyz";
  const std::string format = ErrorFor(options);
  EXPECT_TRUE(StartsWith(format, "--format: ")) << format;
  EXPECT_NE(format.find("expected auto, g2o, isam, mrclam, native or toro"), std::string::npos)
      << format;

  struct Case {
    void (*set)(SolveCommandOptions*);
    std::string prefix;
  };
  const Case cases[] = {
      {[](SolveCommandOptions* o) { o->solver = "foo"; }, "--solver: "},
      {[](SolveCommandOptions* o) { o->preconditioner = "foo"; }, "--preconditioner: "},
      {[](SolveCommandOptions* o) { o->robust_kernel = "bogus"; }, "--robust-kernel: "},
      {[](SolveCommandOptions* o) { o->memory_limit = "lots"; }, "--memory-limit: "},
  };
  for (const Case& c : cases) {
    options = Options();
    c.set(&options);
    const std::string error = ErrorFor(options);
    EXPECT_TRUE(StartsWith(error, c.prefix)) << error;
  }
  options = Options();
  options.initialization = "magic";
  EXPECT_EQ(ErrorFor(options),
            "--initialization must be auto, incremental, progressive, odometry, pose-graph or as-given, got "
            "'magic'");
}

TEST(SolveRequest, RejectsValuesOutOfRangeWithTheirRange) {
  struct Case {
    void (*set)(SolveCommandOptions*);
    std::string message;
  };
  const Case cases[] = {
      // above --pcg-eta-max's default 0.01
      {[](SolveCommandOptions* o) { o->pcg_eta_min = 0.5; },
       "--pcg-eta-min must be in (0, --pcg-eta-max = 0.01], got 0.5"},
      {[](SolveCommandOptions* o) { o->pcg_deflation = 1; },
       "--pcg-deflation must be 0 (off) or >= 2 poses, got 1"},
      {[](SolveCommandOptions* o) { o->pcg_truncation = 1.0; },
       "--pcg-truncation must be in [0, 1), got 1"},
      {[](SolveCommandOptions* o) { o->max_iterations = -1; },
       "--max-iterations must be >= 0, got -1"},
      {[](SolveCommandOptions* o) { o->chunk_observations = 0; },
       "--chunk-observations must be > 0"},
      {[](SolveCommandOptions* o) { o->progressive_max_new_poses = -2; },
       "progressive initialization: max_new_poses must be >= 0 (0: no cap), got -2"},
      {[](SolveCommandOptions* o) { o->input.clear(); }, "no INPUT given"},
  };
  for (const Case& c : cases) {
    SolveCommandOptions options = Options();
    c.set(&options);
    EXPECT_EQ(ErrorFor(options), c.message);
  }
}

TEST(SolveRequest, RejectsCombinationsThatCannotWork) {
  SolveCommandOptions options = Options();
  options.resume = true;  // a file solved in memory has no default checkpoint
  EXPECT_EQ(ErrorFor(options), "--resume needs --checkpoint FILE (or a chunk store as input)");
  options.checkpoint = "cp.json";
  EXPECT_EQ(ErrorFor(options), "");
  options = Options();
  options.resume = true;
  options.workdir = "store/";  // the ingest's store holds the checkpoint
  EXPECT_EQ(ErrorFor(options), "");
  options = Options();
  options.associate = true;
  options.checkpoint = "cp.json";
  EXPECT_EQ(ErrorFor(options), "--associate cannot be combined with --checkpoint/--resume");
  options = Options();
  options.associate = true;
  options.workdir = "store/";
  EXPECT_TRUE(StartsWith(ErrorFor(options), "--associate cannot be combined with --workdir"));
}

TEST(SolverSettings, JobDefaultsAreTheSolversDefaults) {
  StatusOr<core::SolverOptions> options = MakeSolverOptions(SolverSettings());
  ASSERT_TRUE(options.ok()) << options.status().ToString();
  const core::SolverOptions defaults;
  EXPECT_EQ(options->linear_solver, defaults.linear_solver);
  EXPECT_EQ(options->preconditioner, defaults.preconditioner);
  EXPECT_EQ(options->max_iterations, defaults.max_iterations);
  EXPECT_EQ(options->function_tolerance, defaults.function_tolerance);
  EXPECT_EQ(options->initial_trust_region_radius, defaults.initial_trust_region_radius);
  EXPECT_EQ(options->pcg_relative_tolerance, defaults.pcg_relative_tolerance);
  EXPECT_EQ(options->pcg_eta_max, defaults.pcg_eta_max);
  EXPECT_EQ(options->pcg_deflation_poses, defaults.pcg_deflation_poses);
  EXPECT_EQ(options->pcg_truncation, defaults.pcg_truncation);
  EXPECT_EQ(options->max_eliminated_observations, defaults.max_eliminated_observations);
  EXPECT_EQ(options->fused_chunk_pass, defaults.fused_chunk_pass);
  EXPECT_TRUE(options->pose_kernels.AllNone());
}

TEST(SolverSettings, ErrorsUseTheFrontEndsNames) {
  SolverSettings settings;
  settings.linear_solver = "foo";
  const SolverSettingNames job{"solver.linear_solver", "solver.preconditioner",
                               "solver.robust_kernel"};
  StatusOr<core::SolverOptions> options = MakeSolverOptions(settings, job);
  ASSERT_FALSE(options.ok());
  EXPECT_TRUE(StartsWith(options.status().message(), "solver.linear_solver: "))
      << options.status().ToString();
  settings = SolverSettings();
  settings.robust_kernel = "cauchy:-1";
  options = MakeSolverOptions(settings, job);
  ASSERT_FALSE(options.ok());
  EXPECT_TRUE(StartsWith(options.status().message(), "solver.robust_kernel: "))
      << options.status().ToString();
}

}  // namespace
}  // namespace graphslam::tools
