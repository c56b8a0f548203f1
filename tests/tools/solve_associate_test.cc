// End-to-end tests of `graphslam solve --associate` (tools/solve_command.h,
// docs/association.md): an id-less g2o file is refused without --associate
// (naming the line, writing nothing) and associated with it: the output has one
// landmark per physical landmark and every observation as an edge to it.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <algorithm>
#include <map>
#include <sstream>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>
#include <vector>

#include "partition/association/association_driver.h"
#include "storage/chunk_store.h"
#include "storage/g2o_reader.h"
#include "storage/g2o_writer.h"
#include "tools/campus_simulator.h"
#include "tools/exit_codes.h"
#include "tools/ingest_command.h"
#include "tools/solve_command.h"
#include "tests/testing/datasets.h"

namespace graphslam::tools {
namespace {

// Five poses along x; landmarks at (1, 2), (3, -2) and (2, 2) (1 m from the
// first), seen without ids: DATA_FEATURE_POINTXY belongs to the pose before it.
// The (pose, landmark) of each observation line is in the comment.
const char* kIdLessProblem =
    "VERTEX_SE2 0 0 0 0\n"
    "FIX 0\n"
    "DATA_FEATURE_POINTXY 0 2 1.01 2.02 100 0 100\n"   // 0 a
    "VERTEX_SE2 1 1.2 0.3 0.2\n"
    "DATA_FEATURE_POINTXY 0 2 0.02 1.98 100 0 100\n"   // 1 a
    "DATA_FEATURE_POINTXY 0 2 0.99 2.02 100 0 100\n"   // 1 c
    "VERTEX_SE2 2 2.3 -0.4 -0.3\n"
    "DATA_FEATURE_POINTXY 0 2 -0.99 2.01 100 0 100\n"  // 2 a
    "DATA_FEATURE_POINTXY 0 2 0.01 1.99 100 0 100\n"   // 2 c
    "DATA_FEATURE_POINTXY 0 2 1.01 -2.01 100 0 100\n"  // 2 b
    "VERTEX_SE2 3 2.6 0.5 0.35\n"
    "DATA_FEATURE_POINTXY 0 2 -1.02 2.0 100 0 100\n"   // 3 c
    "DATA_FEATURE_POINTXY 0 2 0.0 -2.02 100 0 100\n"   // 3 b
    "VERTEX_SE2 4 4.4 -0.5 -0.25\n"
    "DATA_FEATURE_POINTXY 0 2 -1.01 -1.98 100 0 100\n"  // 4 b
    "EDGE_SE2 0 1 1.01 0.02 0.01 100 0 0 100 0 400\n"
    "EDGE_SE2 1 2 0.98 -0.01 -0.02 100 0 0 100 0 400\n"
    "EDGE_SE2 2 3 1.02 0.01 0.015 100 0 0 100 0 400\n"
    "EDGE_SE2 3 4 0.99 0.02 -0.01 100 0 0 100 0 400\n";

class SolveAssociateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("graphslam_solve_associate_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    input_ = (dir_ / "idless.g2o").string();
    std::ofstream(input_) << kIdLessProblem;
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  // --associate on the id-less input, writing out.g2o and report.json.
  SolveCommandOptions AssociateOptions() const {
    SolveCommandOptions options;
    options.input = input_;
    options.output_g2o = (dir_ / "out.g2o").string();
    options.report = (dir_ / "report.json").string();
    options.associate = true;
    options.association_radius = 3.0;
    options.quiet = true;
    return options;
  }

  // The output's observations (file order a a c a c b c b b, see
  // kIdLessProblem) share a feature exactly when they share a landmark.
  static void ExpectTheThreeLandmarks(const std::string& output_g2o) {
    const auto out = storage::ReadG2o(output_g2o);
    ASSERT_TRUE(out.ok()) << out.status().ToString();
    EXPECT_EQ(out->num_features(), 3);
    ASSERT_EQ(out->observations.size(), 9u);
    const int group[9] = {0, 0, 2, 0, 2, 1, 2, 1, 1};
    for (int i = 0; i < 9; ++i)
      for (int k = 0; k < 9; ++k)
        EXPECT_EQ(out->observations[i].feature == out->observations[k].feature,
                  group[i] == group[k])
            << "observations " << i << " and " << k;
  }

  std::filesystem::path dir_;
  std::string input_;
};

TEST_F(SolveAssociateTest, IdLessInputNeedsAssociate) {
  SolveCommandOptions options;
  options.input = input_;
  options.output_g2o = (dir_ / "out.g2o").string();
  options.quiet = true;
  EXPECT_EQ(RunSolveCommand(options), kExitBadInput);
  EXPECT_FALSE(std::filesystem::exists(options.output_g2o));
}

// The batch rounds alone (--association batch): merges with probabilities.
TEST_F(SolveAssociateTest, AssociatesIdLessObservations) {
  SolveCommandOptions options = AssociateOptions();
  options.association = "batch";
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  ExpectTheThreeLandmarks(options.output_g2o);
  std::ifstream report_file(options.report);
  const nlohmann::json report = nlohmann::json::parse(report_file);
  ASSERT_TRUE(report.contains("association"));
  EXPECT_EQ(report["association"]["initial_features"], 9);
  EXPECT_EQ(report["association"]["final_features"], 3);
  EXPECT_EQ(report["association"]["merges"], 6);
  ASSERT_FALSE(report["association"]["merge_list"].empty());
  EXPECT_GT(report["association"]["merge_list"][0]["probability"].get<double>(), 1e-3);
}

// The incremental pass before the rounds (the default) runs and ends with the
// same correspondences on this easy input.
TEST_F(SolveAssociateTest, IncrementalPassFindsTheSameCorrespondences) {
  const SolveCommandOptions options = AssociateOptions();
  ASSERT_EQ(RunSolveCommand(options), kExitOk);
  ExpectTheThreeLandmarks(options.output_g2o);
  std::ifstream report_file(options.report);
  const nlohmann::json report = nlohmann::json::parse(report_file);
  EXPECT_TRUE(report["association"]["incremental"]["ran"].get<bool>());
  EXPECT_GT(report["association"]["incremental"]["stages"].get<int>(), 0);
  // A few poses: every stage solves the whole prefix.
  EXPECT_EQ(report["association"]["incremental"]["windowed_stages"].get<int>(), 0);
  EXPECT_EQ(report["association"]["incremental"]["largest_window_poses"].get<int>(), 0);
}

double FinalChi2(const std::string& report_path) {
  std::ifstream file(report_path);
  return nlohmann::json::parse(file)["final_chi2"].get<double>();
}

// `graphslam solve STORE/ --associate` on a chunk store made by `graphslam
// ingest`: the same association as the in-memory solve of the same input,
// and the store is rewritten to the associated problem (fewer features, every
// chunk feature-complete, no staging directory left), so a plain solve of it
// continues from the associated optimum.
TEST_F(SolveAssociateTest, ChunkStoreIsAssociatedLikeTheInMemoryProblemAndRewritten) {
  // A small simulated campus where the observations from odd poses see a copy
  // of each landmark (another id): association must merge the copies back.
  CampusSimulatorOptions campus;
  campus.poses = 300;
  campus.gps_every = 25;
  campus.seed = 3;
  StatusOr<SimulatedCampus> simulated = SimulateCampus(campus);
  ASSERT_TRUE(simulated.ok()) << simulated.status().ToString();
  core::Problem2d problem = simulated->problem;
  const int32_t originals = problem.num_features();
  for (int32_t f = 0; f < originals; ++f)
    problem.AddFeature(problem.feature_ids[f] + 500000, problem.features[f], true);
  for (core::Observation& o : problem.observations)
    if (o.pose % 2 == 1) o.feature += originals;
  const std::string input = (dir_ / "copies.g2o").string();
  ASSERT_TRUE(storage::WriteG2o(problem, input).ok());

  const std::string store = (dir_ / "store").string();
  IngestCommandOptions ingest;
  ingest.input = input;
  ingest.output_dir = store;
  ingest.chunk_observations = 150;
  ingest.quiet = true;
  ASSERT_EQ(RunIngestCommand(ingest), kExitOk);
  const int64_t chunks_before = (*storage::DiskChunkSource::Open(store))->NumChunks();

  auto associate = [&](const std::string& in, const std::string& name) {
    SolveCommandOptions options;
    options.input = in;
    options.output_g2o = (dir_ / (name + ".g2o")).string();
    options.report = (dir_ / (name + ".json")).string();
    options.associate = true;
    options.chunk_observations = 150;
    options.quiet = true;
    EXPECT_EQ(RunSolveCommand(options), kExitOk) << name;
    StatusOr<core::Problem2d> out = storage::ReadG2o(options.output_g2o);
    EXPECT_TRUE(out.ok()) << out.status().ToString();
    return std::move(out).value();
  };
  const core::Problem2d memory = associate(input, "memory");
  const core::Problem2d stored = associate(store, "stored");

  // Same clustering of the observations (matched by pose and measurement;
  // the two paths may list them in different orders), same poses and chi2.
  ASSERT_EQ(memory.observations.size(), problem.observations.size());
  ASSERT_EQ(stored.observations.size(), problem.observations.size());
  EXPECT_LT(memory.num_features(), problem.num_features() * 3 / 4) << "copies were merged";
  EXPECT_EQ(memory.num_features(), stored.num_features());
  auto key = [](const core::Problem2d& p, const core::Observation& o) {
    return std::make_tuple(p.pose_ids[o.pose], o.z.x(), o.z.y());
  };
  std::map<std::tuple<int64_t, double, double>, int64_t> memory_feature;
  for (const core::Observation& o : memory.observations)
    memory_feature[key(memory, o)] = memory.feature_ids[o.feature];
  std::map<int64_t, int64_t> stored_to_memory, memory_to_stored;
  for (const core::Observation& o : stored.observations) {
    const auto it = memory_feature.find(key(stored, o));
    ASSERT_NE(it, memory_feature.end()) << "observation of pose " << stored.pose_ids[o.pose];
    const int64_t s = stored.feature_ids[o.feature];
    EXPECT_EQ(stored_to_memory.emplace(s, it->second).first->second, it->second);
    EXPECT_EQ(memory_to_stored.emplace(it->second, s).first->second, s);
  }
  ASSERT_EQ(memory.num_poses(), stored.num_poses());
  for (int32_t i = 0; i < memory.num_poses(); ++i)
    EXPECT_LT((memory.poses[i] - stored.poses[i]).norm(), 1e-6) << "pose " << i;
  const double chi2 = FinalChi2((dir_ / "memory.json").string());
  EXPECT_NEAR(FinalChi2((dir_ / "stored.json").string()), chi2, 1e-8 * chi2);

  // The store now holds the associated problem.
  EXPECT_FALSE(std::filesystem::exists(store + ".associating"));
  StatusOr<std::unique_ptr<storage::DiskChunkSource>> reopened =
      storage::DiskChunkSource::Open(store);
  ASSERT_TRUE(reopened.ok()) << reopened.status().ToString();
  EXPECT_EQ((*reopened)->total_observations(), static_cast<int64_t>(problem.observations.size()));
  // Chunks hold the observed features (the store's problem lists all).
  EXPECT_EQ((*reopened)->total_features(), static_cast<int64_t>(memory_to_stored.size()));
  EXPECT_LE((*reopened)->NumChunks(), chunks_before);
  for (int64_t k = 0; k < (*reopened)->NumChunks(); ++k) {
    core::ObservationChunk chunk;
    ASSERT_TRUE((*reopened)->Load(k, &chunk).ok()) << "chunk " << k;
  }
  StatusOr<core::Problem2d> store_problem = storage::ReadChunkStoreProblem(store);
  ASSERT_TRUE(store_problem.ok());
  EXPECT_EQ(store_problem->num_features(), memory.num_features());
  SolveCommandOptions again;
  again.input = store;
  again.report = (dir_ / "again.json").string();
  again.quiet = true;
  ASSERT_EQ(RunSolveCommand(again), kExitOk);
  EXPECT_NEAR(FinalChi2(again.report), chi2, 1e-6 * chi2);
}

// The first poses of Victoria Park (real laser trees, no ids) up to pose
// `end`: victoriaPark-noassoc.g2o cut there (vertices, their observations and
// the odometry between them), written to `path`.
void CutVictoriaPark(int64_t end, const std::string& path) {
  std::ifstream in(testing::DatasetPath("victoria_park/victoriaPark-noassoc.g2o"));
  std::ofstream out(path);
  std::string line;
  bool inside = true;
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string tag;
    int64_t a = 0, b = 0;
    fields >> tag >> a >> b;
    if (tag == "VERTEX_SE2") inside = a < end;
    if (tag == "EDGE_SE2" ? (a < end && b < end) : inside) out << line << "\n";
  }
}

// Index of the observation of `problem` with `pose_id` and measurement z
// (within 1e-6) not yet taken, or -1.
int64_t FindObservation(const core::Problem2d& problem, int64_t pose_id, const core::Point2& z,
                        std::vector<uint8_t>* taken) {
  for (size_t i = 0; i < problem.observations.size(); ++i) {
    const core::Observation& o = problem.observations[i];
    if ((*taken)[i] || problem.pose_ids[o.pose] != pose_id || (o.z - z).norm() > 1e-6) continue;
    (*taken)[i] = 1;
    return static_cast<int64_t>(i);
  }
  return -1;
}

// `graphslam solve --associate` with its defaults on the first 3 000 poses of
// Victoria Park (1 695 tree sightings, loops closed from pose ~1 850): the
// incremental pass pairs the sightings as the key does; the batch rounds
// alone (--association batch) miss most revisits.
TEST_F(SolveAssociateTest, VictoriaParkSliceIsAssociatedWithDefaults) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-noassoc.g2o");
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  const std::string input = (dir_ / "victoria.g2o").string();
  CutVictoriaPark(3000, input);
  const auto sliced = storage::ReadG2o(input);
  ASSERT_TRUE(sliced.ok()) << sliced.status().ToString();
  // The key: victoriaPark-full.g2o's landmark of the observation with the
  // same pose and measurement (the files list a pose's observations in
  // different orders).
  const auto full = storage::ReadG2o(testing::DatasetPath("victoria_park/victoriaPark-full.g2o"));
  ASSERT_TRUE(full.ok()) << full.status().ToString();
  std::vector<int64_t> key(sliced->observations.size(), -1);
  std::vector<uint8_t> in_key(sliced->observations.size(), 0);
  for (const core::Observation& o : full->observations) {
    const int64_t i = FindObservation(*sliced, full->pose_ids[o.pose], o.z, &in_key);
    if (i >= 0) key[i] = full->feature_ids[o.feature];
  }
  ASSERT_EQ(std::count(key.begin(), key.end(), -1), 0);
  ASSERT_GT(key.size(), 1000u);

  auto score = [&](const std::string& association) {
    SolveCommandOptions options;
    options.input = input;
    options.output_g2o = (dir_ / (association + ".g2o")).string();
    options.associate = true;
    options.association = association;
    options.quiet = true;
    EXPECT_EQ(RunSolveCommand(options), kExitOk) << association;
    const auto out = storage::ReadG2o(options.output_g2o);
    EXPECT_TRUE(out.ok()) << out.status().ToString();
    // Each output observation is matched to its input by pose and
    // measurement; observations dropped as clutter pair with nothing.
    std::vector<int64_t> labels(key.size());
    for (size_t i = 0; i < labels.size(); ++i) labels[i] = -1 - static_cast<int64_t>(i);
    std::vector<uint8_t> matched(key.size(), 0);
    for (const core::Observation& o : out->observations) {
      const int64_t i = FindObservation(*sliced, out->pose_ids[o.pose], o.z, &matched);
      EXPECT_GE(i, 0) << "output observation of pose " << out->pose_ids[o.pose];
      if (i >= 0) labels[i] = out->feature_ids[o.feature];
    }
    return partition::ScorePairwise(labels, key);
  };
  // Measured 0.956 / 0.992 (incremental; 0.983 before provisional features
  // were re-tested against the final map) and 0.821 / 0.494 (batch); the
  // precision lost is mostly the key's own doubled trees (docs/association.md).
  const partition::PairwiseScore incremental = score("incremental");
  EXPECT_GE(incremental.precision(), 0.94);
  EXPECT_GE(incremental.recall(), 0.985);
  const partition::PairwiseScore batch = score("batch");
  EXPECT_LT(batch.recall(), 0.7);
}

}  // namespace
}  // namespace graphslam::tools
