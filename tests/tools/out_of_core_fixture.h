// The fixture the out-of-core command-line tests share: a fresh temporary
// folder per test, the 2-run simulated campus with GPS as input, and the
// comparison of two solve reports (final chi2 within 1e-9 relative, same
// observation count and residual dimension).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "tests/testing/subprocess.h"

namespace graphslam::testing {

namespace fs = std::filesystem;

inline nlohmann::json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

class OutOfCoreFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(GraphslamBinary())) << GraphslamBinary();
    const ::testing::TestInfo* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("graphslam_ooc_" + std::string(info->name()) + "_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Simulate(int poses, int seed) {
    const fs::path out = dir_ / ("sim" + std::to_string(seed));
    EXPECT_EQ(RunGraphslam({"simulate", "-o", out.string(), "--poses", std::to_string(poses),
                            "--runs", "2", "--gps-every", "25", "--seed", std::to_string(seed),
                            "-q"}),
              0);
    return (out / "log.graphslam").string();
  }

  static void ExpectSameChi2(const nlohmann::json& a, const nlohmann::json& b) {
    const double ca = a["final_chi2"].get<double>(), cb = b["final_chi2"].get<double>();
    EXPECT_LE(std::abs(ca - cb), 1e-9 * std::abs(ca)) << ca << " vs " << cb;
    EXPECT_EQ(a["observations"], b["observations"]);
    EXPECT_EQ(a["residual_dimension"], b["residual_dimension"]);
  }

  fs::path dir_;
};

}  // namespace graphslam::testing
