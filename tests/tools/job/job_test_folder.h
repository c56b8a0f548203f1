// Test fixture of the in-process job tests: a private temporary folder per
// test (removed afterwards), a job file written into it and run with
// RunJob (quiet), and whole-file readers for the outputs.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "core/status.h"
#include "tools/job/job_runner.h"

namespace graphslam::tools::job {

class JobTestFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    const ::testing::TestInfo* test = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("graphslam_" + std::string(test->test_suite_name()) + "_" + std::to_string(getpid()));
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // Writes `yaml` to DIR/name and runs it as a job.
  Status Run(const std::string& yaml, const std::string& name = "job.yaml") {
    std::ofstream((dir_ / name).string()) << yaml;
    RunJobOptions options;
    options.job_path = (dir_ / name).string();
    options.quiet = true;
    return RunJob(options);
  }

  static std::string ReadFile(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream buffer;
    buffer << in.rdbuf();
    return buffer.str();
  }
  static nlohmann::json ReadJsonFile(const std::filesystem::path& path) {
    return nlohmann::json::parse(ReadFile(path));
  }

  std::filesystem::path dir_;
};

}  // namespace graphslam::tools::job
