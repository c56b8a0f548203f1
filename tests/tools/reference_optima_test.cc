// Real datasets reach the optimum of a converged Levenberg-Marquardt solver
// with `graphslam solve`'s default options (../shared/datasets/INDEX.md lists
// g2o's optima; "a correct solver reaches these within 0.1 % or lower").
//
// Victoria Park: g2o's LM stops at 12058.87, a local minimum; our default
// (--initialization auto: the odometry start is abandoned at a step with
// rho < 0.25, then incremental initialization) reaches 389.7874 — the lowest chi2 any of our
// runs found, confirmed by an independent chi2 evaluation of the written graph.
// Incremental initialization is also what the default does at once where it
// does not try odometry first (chunk stores, jobs): it keeps every optimum.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/testing/datasets.h"
#include "tools/exit_codes.h"
#include "tools/solve_command.h"

namespace graphslam::tools {
namespace {

// `initialization_used` is what --initialization auto did: "odometry" when
// the solve from Table 1's guess was never abandoned, else "incremental".
// `input_chi2` (optional) receives the chi2 of the file's own estimate.
// `initialization`: the option given (the default "auto" when empty).
double SolveWithDefaults(const std::string& relative, const std::string& initialization_used,
                         double* input_chi2 = nullptr, const std::string& initialization = "") {
  const std::string report =
      (std::filesystem::temp_directory_path() /
       ("graphslam_reference_" + std::to_string(::getpid()) + ".json"))
          .string();
  SolveCommandOptions options;
  options.input = graphslam::testing::DatasetPath(relative);
  options.report = report;
  options.quiet = true;
  if (!initialization.empty()) options.initialization = initialization;
  EXPECT_EQ(RunSolveCommand(options), kExitOk) << relative;
  std::ifstream in(report);
  const nlohmann::json json = nlohmann::json::parse(in, nullptr, false);
  std::filesystem::remove(report);
  if (json.is_discarded()) return -1.0;
  EXPECT_TRUE(json["converged"].get<bool>()) << relative;
  EXPECT_EQ(json["initialization"].get<std::string>(),
            initialization.empty() ? "auto" : initialization)
      << relative;
  EXPECT_EQ(json["initialization_used"].get<std::string>(), initialization_used) << relative;
  // Never stopped by the iteration cap (issue 25).
  EXPECT_LT(json["iterations"].get<int>(), options.max_iterations) << relative;
  if (input_chi2 != nullptr) *input_chi2 = json.value("input_chi2", -1.0);
  return json["final_chi2"].get<double>();
}

// Within 0.1 % of the reference, or lower.
void ExpectReached(double chi2, double reference) {
  EXPECT_GT(chi2, 0.0);
  EXPECT_LE(chi2, reference * 1.001) << "reference " << reference;
}

TEST(ReferenceOptima, IntelReachesG2oOptimum) {
  GS_REQUIRE_DATASET("freiburg_course_g2o/intel.g2o");
  const double chi2 = SolveWithDefaults("freiburg_course_g2o/intel.g2o", "odometry");
  ExpectReached(chi2, 359.996112);
  EXPECT_NEAR(chi2, 359.996112, 1e-3 * 359.996112);
}

TEST(ReferenceOptima, M3500ReachesG2oOptimum) {
  GS_REQUIRE_DATASET("freiburg_course_g2o/input_M3500_g2o.g2o");
  const double chi2 = SolveWithDefaults("freiburg_course_g2o/input_M3500_g2o.g2o", "odometry");
  ExpectReached(chi2, 137.912951);
  EXPECT_NEAR(chi2, 137.912951, 1e-3 * 137.912951);
}

TEST(ReferenceOptima, VictoriaParkReachesBelowG2oLocalMinimum) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  double input_chi2 = 0.0;
  const double chi2 =
      SolveWithDefaults("victoria_park/victoriaPark-full.g2o", "incremental", &input_chi2);
  ExpectReached(chi2, 12058.87);
  EXPECT_NEAR(chi2, 389.7874, 1e-3 * 389.7874);
  // The file's own guess, as g2o reports it (84 128 052), beside the start
  // after incremental initialization.
  EXPECT_NEAR(input_chi2, 84128052.0, 1.0);
}

TEST(ReferenceOptima, City10000ReachesG2oOptimumOrLower) {
  GS_REQUIRE_DATASET("sesync_posegraphs/city10000.g2o");
  const double chi2 = SolveWithDefaults("sesync_posegraphs/city10000.g2o", "odometry");
  ExpectReached(chi2, 1484.685685);
}

// The pose graphs converge from odometry by default; from incremental
// initialization (the default's restart, and the default of stores and jobs)
// they reach the same optima.
TEST(ReferenceOptima, IncrementalInitializationKeepsThePoseGraphOptima) {
  for (const auto& [file, optimum] : {std::pair{"freiburg_course_g2o/intel.g2o", 359.996112},
                                      std::pair{"freiburg_course_g2o/input_M3500_g2o.g2o", 137.912951},
                                      std::pair{"sesync_posegraphs/city10000.g2o", 1484.685685}}) {
    GS_REQUIRE_DATASET(file);
    const double chi2 = SolveWithDefaults(file, "incremental", nullptr, "incremental");
    ExpectReached(chi2, optimum);
  }
}

}  // namespace
}  // namespace graphslam::tools
