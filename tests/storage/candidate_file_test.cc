// CandidateFile (storage/candidate_file.h): the streaming solve's candidate
// feature estimates on disk. What is appended comes back bit for bit and in
// order; a flipped byte or a truncated file is Corruption naming the file and
// the byte offset; and a solve that keeps its candidates in the file equals
// the in-memory solve bit for bit (chi2 per iteration, poses, features) for
// several chunk sizes, thread counts and both pass schedules, also when it is
// stopped and resumed from a checkpoint whose feature estimates are in a
// feature file (storage/solver_checkpoint.h).
#include "storage/candidate_file.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <vector>

#include "core/graphslam_solver.h"
#include "partition/ingest/in_memory_chunk_source.h"
#include "storage/solver_checkpoint.h"
#include "tests/testing/random_problem.h"

namespace graphslam::storage {
namespace {

namespace fs = std::filesystem;

class CandidateFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("graphslam_candidates_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) + "_" +
            std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

struct Entry {
  int32_t feature;
  core::Point2 value;
};

std::vector<Entry> ReadAll(CandidateFile* file, Status* status) {
  std::vector<Entry> out;
  *status = file->ForEach([&](int32_t g, const core::Point2& v) { out.push_back({g, v}); });
  return out;
}

// Three chunks of candidates, with values whose bits a text round trip could lose.
std::vector<std::vector<Entry>> SomeChunks() {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1e3);
  std::vector<std::vector<Entry>> chunks(3);
  int32_t g = 0;
  for (size_t c = 0; c < chunks.size(); ++c)
    for (int k = 0; k < 50 + 30 * static_cast<int>(c); ++k)
      chunks[c].push_back({g++ * 3 + 1, core::Point2(n(rng), std::nextafter(n(rng), 0.0))});
  chunks[1][0].value = core::Point2(-0.0, std::numeric_limits<double>::denorm_min());
  return chunks;
}

Status AppendChunks(const std::vector<std::vector<Entry>>& chunks, CandidateFile* file) {
  GS_RETURN_IF_ERROR(file->Begin());
  for (size_t c = 0; c < chunks.size(); ++c) {
    std::vector<int32_t> ids;
    std::vector<core::Point2> values;
    for (const Entry& e : chunks[c]) {
      ids.push_back(e.feature);
      values.push_back(e.value);
    }
    GS_RETURN_IF_ERROR(file->Append(static_cast<int64_t>(c), ids.data(), values.data(),
                                    static_cast<int64_t>(ids.size())));
  }
  return file->Finish();
}

TEST_F(CandidateFileTest, ForEachGivesBackTheAppendedCandidatesBitForBitInOrder) {
  const std::string path = (dir_ / "candidates.bin").string();
  {
    CandidateFile file(Env::Default(), path);
    Status status;
    ReadAll(&file, &status);
    EXPECT_FALSE(status.ok()) << "no finished step yet";
    const std::vector<std::vector<Entry>> chunks = SomeChunks();
    ASSERT_TRUE(AppendChunks(chunks, &file).ok());
    const std::vector<Entry> read = ReadAll(&file, &status);
    ASSERT_TRUE(status.ok()) << status.ToString();
    size_t i = 0;
    for (const auto& chunk : chunks) {
      for (const Entry& e : chunk) {
        ASSERT_LT(i, read.size());
        EXPECT_EQ(read[i].feature, e.feature);
        EXPECT_EQ(std::memcmp(read[i].value.data(), e.value.data(), sizeof(double) * 2), 0)
            << "entry " << i;
        ++i;
      }
    }
    EXPECT_EQ(i, read.size());
    // A new step forgets the last one.
    ASSERT_TRUE(file.Begin().ok());
    const int32_t id = 7;
    const core::Point2 value(1.5, -2.5);
    ASSERT_TRUE(file.Append(0, &id, &value, 1).ok());
    ASSERT_TRUE(file.Finish().ok());
    const std::vector<Entry> second = ReadAll(&file, &status);
    ASSERT_TRUE(status.ok());
    ASSERT_EQ(second.size(), 1u);
    EXPECT_EQ(second[0].feature, 7);
    EXPECT_EQ(second[0].value, value);
  }
  EXPECT_FALSE(fs::exists(path)) << "the scratch file outlived its store";
}

TEST_F(CandidateFileTest, FlippedByteOrTruncationIsCorruptionNamingFileAndOffset) {
  const std::string path = (dir_ / "candidates.bin").string();
  CandidateFile file(Env::Default(), path);
  ASSERT_TRUE(AppendChunks(SomeChunks(), &file).ok());
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // Header 24 bytes, then the first record (9-byte frame, 12 + 20 * 50 bytes);
  // the second record starts at 24 + 9 + 1012 = 1045.
  const int64_t second_record = 24 + 9 + 12 + 20 * 50;
  const auto write = [&](const std::string& contents) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << contents;
  };
  std::string flipped = bytes;
  flipped[second_record + 9 + 40] ^= 0x10;
  write(flipped);
  Status status;
  ReadAll(&file, &status);
  EXPECT_EQ(status.code(), Status::Code::kCorruption) << status.ToString();
  EXPECT_NE(status.message().find(path), std::string::npos) << status.ToString();
  EXPECT_NE(status.message().find("offset " + std::to_string(second_record)), std::string::npos)
      << status.ToString();
  EXPECT_NE(status.message().find("checksum"), std::string::npos) << status.ToString();

  write(bytes.substr(0, second_record + 100));  // cut inside the second record
  ReadAll(&file, &status);
  EXPECT_EQ(status.code(), Status::Code::kCorruption) << status.ToString();
  EXPECT_NE(status.message().find("offset " + std::to_string(second_record)), std::string::npos)
      << status.ToString();

  write(bytes.substr(0, bytes.size() - 25));  // the footer is gone
  ReadAll(&file, &status);
  EXPECT_EQ(status.code(), Status::Code::kCorruption) << status.ToString();
  EXPECT_NE(status.message().find("no footer"), std::string::npos) << status.ToString();
}

core::Problem2d TestProblem() {
  testing::RandomProblemOptions options;
  options.num_poses = 120;
  options.num_features = 40;
  options.gps_every = 10;
  options.seed = 21;
  return testing::MakeRandomProblem(options).problem;
}

void ExpectSameSolve(const core::Problem2d& a, const core::SolverSummary& sa,
                     const core::Problem2d& b, const core::SolverSummary& sb) {
  EXPECT_EQ(sa.final_chi2, sb.final_chi2);
  ASSERT_EQ(sa.per_iteration.size(), sb.per_iteration.size());
  for (size_t i = 0; i < sa.per_iteration.size(); ++i) {
    EXPECT_EQ(sa.per_iteration[i].candidate_chi2, sb.per_iteration[i].candidate_chi2) << i;
    EXPECT_EQ(sa.per_iteration[i].accepted, sb.per_iteration[i].accepted) << i;
    EXPECT_EQ(sa.per_iteration[i].line_search_fraction, sb.per_iteration[i].line_search_fraction)
        << i;
  }
  for (int p = 0; p < a.num_poses(); ++p) EXPECT_EQ(a.poses[p], b.poses[p]) << "pose " << p;
  for (int j = 0; j < a.num_features(); ++j)
    EXPECT_EQ(a.features[j], b.features[j]) << "feature " << j;
}

// Solves `start` in memory, then again with its candidates in a file in
// `dir`, and expects the same solve bit for bit; the file's summary goes to
// *on_disk_summary.
void ExpectFileSolveEqualsInMemorySolve(const fs::path& dir, const core::Problem2d& start,
                                        const partition::InMemoryChunkSource& chunks,
                                        core::SolverOptions options,
                                        core::SolverSummary* on_disk_summary) {
  core::Problem2d in_memory = start;
  core::SolverSummary in_memory_summary;
  ASSERT_TRUE(core::SolveGraphSlam(options, chunks, &in_memory, &in_memory_summary).ok());
  CandidateFile file(Env::Default(), (dir / "candidates.bin").string());
  options.candidate_store = &file;
  core::Problem2d on_disk = start;
  ASSERT_TRUE(core::SolveGraphSlam(options, chunks, &on_disk, on_disk_summary).ok());
  ExpectSameSolve(in_memory, in_memory_summary, on_disk, *on_disk_summary);
}

TEST_F(CandidateFileTest, SolveWithTheFileEqualsTheInMemorySolveBitForBit) {
  const core::Problem2d start = TestProblem();
  for (int64_t chunk_observations : {40, 1000}) {
    for (int threads : {1, 2}) {
      for (bool fused : {true, false}) {
        SCOPED_TRACE("chunk " + std::to_string(chunk_observations) + ", threads " +
                     std::to_string(threads) + (fused ? ", fused" : ", two-pass"));
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        partition::ChunkingOptions chunking;
        chunking.max_observations_per_chunk = chunk_observations;
        partition::InMemoryChunkSource chunks(start, chunking);
        core::SolverOptions options;
        options.max_iterations = 8;
        options.fused_chunk_pass = fused;
        options.max_eliminated_observations = 30;  // some kept features too
        core::SolverSummary on_disk_summary;
        ASSERT_NO_FATAL_FAILURE(
            ExpectFileSolveEqualsInMemorySolve(dir_, start, chunks, options, &on_disk_summary));
        EXPECT_GT(on_disk_summary.kept_features, 0);
      }
    }
  }
}

// Headings off by up to 2.5 rad: full steps overshoot and are rejected, and
// the line search takes a fraction of them. With the candidates in the file
// (which holds no x to scale them from) the line search recovers the step
// again and scales each candidate: the same solve as in memory, bit for bit,
// line steps included.
TEST_F(CandidateFileTest, LineSearchWithTheFileEqualsTheInMemoryLineSearch) {
  int line_steps = 0;
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    for (bool fused : {true, false}) {
      SCOPED_TRACE("seed " + std::to_string(seed) + (fused ? ", fused" : ", two-pass"));
      testing::RandomProblemOptions random;
      random.num_poses = 40;
      random.num_features = 15;
      random.seed = seed;
      core::Problem2d start = testing::MakeRandomProblem(random).problem;
      std::mt19937 rng(seed);
      std::uniform_real_distribution<double> heading(-2.5, 2.5);
      for (int p = 1; p < start.num_poses(); ++p) start.poses[p].z() += heading(rng);
      partition::ChunkingOptions chunking;
      chunking.max_observations_per_chunk = 40;
      partition::InMemoryChunkSource chunks(start, chunking);
      core::SolverOptions options;
      options.linear_solver = core::LinearSolverType::kCholmod;
      options.function_tolerance = 1e-12;
      options.max_iterations = 60;
      options.fused_chunk_pass = fused;
      options.max_eliminated_observations = 12;  // some kept features too
      core::SolverSummary on_disk_summary;
      ASSERT_NO_FATAL_FAILURE(
          ExpectFileSolveEqualsInMemorySolve(dir_, start, chunks, options, &on_disk_summary));
      for (const core::IterationSummary& it : on_disk_summary.per_iteration)
        if (it.line_search_fraction > 0.0) ++line_steps;
    }
  }
  EXPECT_GT(line_steps, 0);
}

TEST_F(CandidateFileTest, ResumeFromAFeatureFileCheckpointEqualsTheUninterruptedSolve) {
  const core::Problem2d start = TestProblem();
  partition::ChunkingOptions chunking;
  chunking.max_observations_per_chunk = 60;
  partition::InMemoryChunkSource chunks(start, chunking);
  core::SolverOptions options;
  options.max_iterations = 7;
  options.function_tolerance = 1e-14;
  core::Problem2d full = start;
  core::SolverSummary full_summary;
  ASSERT_TRUE(core::SolveGraphSlam(options, chunks, &full, &full_summary).ok());

  // "Killed" after 3 iterations: the last checkpoint names generation 3.
  const std::string checkpoint_path = (dir_ / "checkpoint.json").string();
  CandidateFile file(Env::Default(), (dir_ / "candidates.bin").string());
  options.candidate_store = &file;
  options.checkpoint_callback = [&](const core::SolverCheckpoint& c) {
    return WriteSolverCheckpointWithFeatureFile(Env::Default(), checkpoint_path, "in", c);
  };
  options.max_iterations = 3;
  core::Problem2d first = start;
  core::SolverSummary first_summary;
  ASSERT_TRUE(core::SolveGraphSlam(options, chunks, &first, &first_summary).ok());
  EXPECT_TRUE(fs::exists(checkpoint_path + ".features.3.bin"));
  EXPECT_FALSE(fs::exists(checkpoint_path + ".features.2.bin")) << "old generation kept";

  StatusOr<core::SolverCheckpoint> checkpoint = ReadSolverCheckpoint(checkpoint_path, "in");
  ASSERT_TRUE(checkpoint.ok()) << checkpoint.status().ToString();
  EXPECT_EQ(checkpoint->iterations, 3);
  options.max_iterations = 7;
  options.resume_from = &*checkpoint;
  core::Problem2d resumed = start;  // the ingest's guess, as after a restart
  core::SolverSummary resumed_summary;
  ASSERT_TRUE(core::SolveGraphSlam(options, chunks, &resumed, &resumed_summary).ok());
  EXPECT_EQ(resumed_summary.resumed_from_iteration, 3);
  EXPECT_EQ(resumed_summary.final_chi2, full_summary.final_chi2);
  for (int p = 0; p < full.num_poses(); ++p) EXPECT_EQ(resumed.poses[p], full.poses[p]) << p;
  for (int j = 0; j < full.num_features(); ++j)
    EXPECT_EQ(resumed.features[j], full.features[j]) << "feature " << j;
}

}  // namespace
}  // namespace graphslam::storage
