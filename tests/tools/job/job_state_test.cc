// The job checkpoint (state.json) and the JSON-lines log.
#include "tools/job/job_state.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace graphslam::tools::job {
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) {
  fs::path dir = fs::temp_directory_path() / (name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

TEST(JobState, FingerprintIsFnv1a64) {
  // FNV-1a 64 reference values (offset basis for "", and "a").
  EXPECT_EQ(Fingerprint(""), "cbf29ce484222325");
  EXPECT_EQ(Fingerprint("a"), "af63dc4c8601ec8c");
  EXPECT_NE(Fingerprint("output: a\n"), Fingerprint("output: b\n"));
}

TEST(JobState, RoundTrip) {
  const fs::path dir = TempDir("graphslam_job_state");
  JobState state;
  state.job_fingerprint = "0123456789abcdef";
  state.completed.push_back({"ingest", 1.25, 1000});
  state.completed.push_back({"initialize", 0.5, 2000});
  ASSERT_TRUE(WriteJobState((dir / "state.json").string(), state).ok());
  StatusOr<JobState> read = ReadJobState((dir / "state.json").string());
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->job_fingerprint, state.job_fingerprint);
  ASSERT_EQ(read->completed.size(), 2u);
  EXPECT_TRUE(read->IsCompleted("initialize"));
  EXPECT_FALSE(read->IsCompleted("optimize"));
  EXPECT_DOUBLE_EQ(read->Find("ingest")->seconds, 1.25);
  EXPECT_EQ(read->Find("initialize")->peak_rss_bytes, 2000);
  fs::remove_all(dir);
}

TEST(JobState, CorruptFilesAreNamed) {
  const fs::path dir = TempDir("graphslam_job_state_bad");
  const std::string path = (dir / "state.json").string();
  for (const std::string& text :
       {std::string("{not json"), std::string("{\"format\": \"other\", \"version\": 1}"),
        std::string("{\"format\": \"graphslam-job-state\", \"version\": 1}"),
        std::string("{\"format\": \"graphslam-job-state\", \"version\": 1, "
                    "\"job_fingerprint\": \"x\", \"completed\": [{}]}")}) {
    std::ofstream(path) << text;
    StatusOr<JobState> read = ReadJobState(path);
    ASSERT_FALSE(read.ok()) << text;
    EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
    EXPECT_THAT(read.status().message(), ::testing::HasSubstr(path));
  }
  std::ofstream(path) << "{\"format\": \"graphslam-job-state\", \"version\": 99}";
  EXPECT_TRUE(ReadJobState(path).status().IsNotSupported());
  fs::remove_all(dir);
}

TEST(JobLog, AppendsOneJsonObjectPerLine) {
  const fs::path dir = TempDir("graphslam_job_log");
  const std::string path = (dir / "log.jsonl").string();
  {
    JobLog log;
    ASSERT_TRUE(log.Open(path).ok());
    log.Write({{"event", "a"}, {"n", 1}});
  }
  {
    JobLog log;  // a resumed job appends
    ASSERT_TRUE(log.Open(path).ok());
    log.Write({{"event", "b"}});
  }
  std::ifstream in(path);
  std::string line;
  std::vector<nlohmann::json> lines;
  while (std::getline(in, line)) lines.push_back(nlohmann::json::parse(line));
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0]["event"], "a");
  EXPECT_EQ(lines[0]["n"], 1);
  EXPECT_EQ(lines[1]["event"], "b");
  EXPECT_EQ(lines[1]["time"].get<std::string>().size(), 24u);  // 2026-01-02T03:04:05.678Z
  fs::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::tools::job
