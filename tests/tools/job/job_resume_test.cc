// kill -9 at several points of a job, then `graphslam run --resume`: the
// final outputs equal those of an uninterrupted run byte for byte.
//
// The graphslam binary runs as a child process (as in solve_resume_test.cc)
// on a simulated two-run campus with GPS and is killed at named stop points
// (storage/stop_point.h): a stage's start, a completed stage, the solver
// checkpoint of an iteration, the first fused batch of scans. The job has
// scans, so the map stage (OctoMap fusion) is killed too, and the outputs of
// an earlier job in the folder must survive a killed new one.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cctype>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "tests/testing/kill_nine.h"
#include "tests/testing/subprocess.h"

namespace {

namespace fs = std::filesystem;

const std::string kGraphslam = graphslam::testing::GraphslamBinary();
const auto Spawn = &graphslam::testing::SpawnGraphslam;
const auto Wait = &graphslam::testing::WaitForExit;

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

// The deterministic outputs (the report holds wall times, so it is not one).
std::vector<std::string> kCompared = {"trajectories/campus_1.tum", "trajectories/campus_2.tum",
                                      "trajectories/campus_1_groundtruth.tum", "map.runs.json",
                                      "features.csv", "graph.g2o", "map.bt", "map.pcd"};

class JobResume : public ::testing::Test {
 protected:
  // One uninterrupted reference run for all tests.
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("graphslam_job_resume_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    job_ = (dir_ / "job.yaml").string();
    std::ofstream(job_) << "output: reference\n"
                           "threads: 2\n"
                           "solver: {max_iterations: 20, function_tolerance: 1e-9, initialization: odometry}\n"
                           "map: {resolution: 0.25, max_range: 25}\n"
                           "runs:\n"
                           "  - name: campus\n"
                           "    format: simulate\n"
                           "    simulate: {poses: 600, runs: 2, gps_every: 20, seed: 11, scans: true,\n"
                           "               scan_beams: 60, scan_max_range: 25}\n";
    reference_ok_ = fs::exists(kGraphslam) && Wait(Spawn({"run", job_, "-q"})) == 0;
    for (const std::string& file : kCompared) reference_.push_back(ReadFile(dir_ / "reference" / file));
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  void SetUp() override {
    ASSERT_TRUE(fs::exists(kGraphslam)) << kGraphslam;
    ASSERT_TRUE(reference_ok_) << "the uninterrupted reference job failed";
    for (const std::string& r : reference_) ASSERT_FALSE(r.empty());
  }

  // Starts the job into `name`, kills it with SIGKILL at the stop point
  // `point` (storage/stop_point.h: the child stops itself there, so the kill
  // lands at exactly that step on any machine), resumes it, and compares the
  // outputs with the uninterrupted run's. Returns false if the job ended
  // without reaching `point` (nothing was interrupted).
  // `before_resume` (optional) runs between the kill and the resume.
  bool KillAndResume(const std::string& name, const std::string& point,
                     const std::function<void(const fs::path&)>& before_resume = nullptr) {
    const fs::path out = dir_ / name;
    const bool killed = graphslam::testing::SpawnAndKillAtStopPoint(
        {"run", job_, "-o", out.string(), "-q"}, point);
    if (before_resume) before_resume(out);
    EXPECT_EQ(Wait(Spawn({"run", job_, "-o", out.string(), "--resume", "-q"})), 0) << name;
    for (size_t k = 0; k < kCompared.size(); ++k)
      EXPECT_EQ(ReadFile(out / kCompared[k]), reference_[k]) << name << ": " << kCompared[k];
    return killed;
  }

  static inline fs::path dir_;
  static inline std::string job_;
  static inline bool reference_ok_ = false;
  static inline std::vector<std::string> reference_;
};

bool LogHas(const fs::path& out, const std::string& text) {
  return ReadFile(out / "log.jsonl").find(text) != std::string::npos;
}

TEST_F(JobResume, KillDuringIngest) {
  EXPECT_TRUE(KillAndResume("ingest", "job_stage_start ingest"));
}

TEST_F(JobResume, KillBetweenStages) {
  EXPECT_TRUE(KillAndResume("initialized", "job_stage_done initialize"));
}

TEST_F(JobResume, KillInTheMiddleOfTheOptimization) {
  const bool killed = KillAndResume("optimize", "solver_checkpoint 1");
  EXPECT_TRUE(killed);
  // The resumed solve continued from the checkpoint (the log says so).
  EXPECT_TRUE(LogHas(dir_ / "optimize", "resuming after iteration"));
}

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

const std::string kMapStart = "\"event\":\"stage_start\",\"stage\":\"map\"";

TEST_F(JobResume, KillDuringMapFusion) {
  bool map_done_at_kill = true;
  EXPECT_TRUE(KillAndResume("map", "map_batch 1", [&](const fs::path& out) {
    map_done_at_kill = ReadFile(out / ".job/state.json").find("\"map\"") != std::string::npos;
  }));
  // Killed inside the map stage, which the resumed job ran again.
  EXPECT_FALSE(map_done_at_kill);
  EXPECT_EQ(Count(ReadFile(dir_ / "map" / "log.jsonl"), kMapStart), 2);
}

TEST_F(JobResume, AKilledJobLeavesTheOutputsOfTheEarlierJobUntouched) {
  // An earlier job's outputs (stand-ins) in the folder; a new job killed
  // during its map fusion must not touch them; its resume replaces them.
  const fs::path out = dir_ / "earlier";
  fs::create_directories(out / "trajectories");
  for (const std::string& file : kCompared) std::ofstream(out / file) << "earlier " << file;
  EXPECT_TRUE(KillAndResume("earlier", "map_batch 1", [](const fs::path& out) {
    for (const std::string& file : kCompared)
      EXPECT_EQ(ReadFile(out / file), "earlier " + file) << file;
  }));
}

TEST_F(JobResume, KillDuringExport) {
  EXPECT_TRUE(KillAndResume("export", "job_stage_start export"));
}

TEST_F(JobResume, ResumeIsRefusedWhenTheJobFileChanged) {
  const fs::path out = dir_ / "changed";
  const std::string job = (dir_ / "changed.yaml").string();
  fs::copy_file(job_, job);
  ASSERT_EQ(Wait(Spawn({"run", job, "-o", out.string(), "-q"})), 0);
  std::ofstream(job, std::ios::app) << "# edited\n";
  EXPECT_NE(Wait(Spawn({"run", job, "-o", out.string(), "--resume", "-q"})), 0);
  // Run afresh over the same folder: the same bytes again (determinism).
  const std::string before = ReadFile(out / "graph.g2o");
  fs::copy_file(job_, job, fs::copy_options::overwrite_existing);
  EXPECT_EQ(Wait(Spawn({"run", job, "-o", out.string(), "-q"})), 0);
  EXPECT_EQ(ReadFile(out / "graph.g2o"), before);
}

// The solver checkpoint of an interrupted optimize stage is sealed
// (storage/sealed_json_text.h): a digit changed in it while the job was
// down makes --resume fail naming the file, not resume from edited state.
TEST_F(JobResume, EditedCheckpointOfAnInterruptedStageIsRefused) {
  const fs::path out = dir_ / "edited";
  ASSERT_TRUE(graphslam::testing::SpawnAndKillAtStopPoint({"run", job_, "-o", out.string(), "-q"},
                                                          "solver_checkpoint 1"));
  const fs::path checkpoint = out / ".job" / "optimize_c0.checkpoint.json";
  std::string text = ReadFile(checkpoint);
  const size_t digit = text.find("\"chi2\":") + 7;
  ASSERT_LT(digit, text.size());
  ASSERT_TRUE(std::isdigit(static_cast<unsigned char>(text[digit]))) << text.substr(0, 400);
  text[digit] = text[digit] == '9' ? '8' : static_cast<char>(text[digit] + 1);
  std::ofstream(checkpoint, std::ios::binary | std::ios::trunc) << text;
  const std::string log = (dir_ / "edited_stderr.txt").string();
  EXPECT_EQ(Wait(graphslam::testing::SpawnGraphslamRedirected(
                {"run", job_, "-o", out.string(), "--resume", "-q"}, log)),
            2);
  EXPECT_NE(ReadFile(log).find(checkpoint.string() + ": crc32c of its"), std::string::npos)
      << ReadFile(log);
}

}  // namespace
