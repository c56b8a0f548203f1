// Solver checkpoints on disk (storage/solver_checkpoint.h): 2-D and 3-D
// states read back bit for bit; a checkpoint of the other dimension, of
// another input, or with a truncated pose array is refused with the path.
#include "storage/solver_checkpoint.h"
#include "storage/sealed_json_text.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <tuple>

#include "core/se3_lie.h"
#include "tests/testing/directory_bytes.h"

namespace graphslam::storage {
namespace {

std::string TempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() /
          ("graphslam_checkpoint_" + std::to_string(::getpid()) + "_" + name))
      .string();
}

template <class Checkpoint>
void FillControl(Checkpoint* c) {
  c->iterations = 7;
  c->trust_region_radius = 1.0 / 3.0;
  c->decrease_factor = 8.0;
  c->initial_chi2 = 12345.678901234567;
  c->chi2 = std::nextafter(99.1, 100.0);
  c->converged = false;
  c->termination = "";
}

template <class Checkpoint>
void ExpectSameControl(const Checkpoint& a, const Checkpoint& b) {
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.trust_region_radius, b.trust_region_radius);
  EXPECT_EQ(a.decrease_factor, b.decrease_factor);
  EXPECT_EQ(a.initial_chi2, b.initial_chi2);
  EXPECT_EQ(a.chi2, b.chi2);
  EXPECT_EQ(a.converged, b.converged);
  EXPECT_EQ(a.termination, b.termination);
  EXPECT_EQ(a.excluded, b.excluded);
  EXPECT_EQ(a.kept, b.kept);
}

TEST(SolverCheckpoint, PlanarStateReadsBackBitForBit) {
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0.0, 10.0);
  core::SolverCheckpoint c;
  FillControl(&c);
  for (int i = 0; i < 20; ++i) c.poses.emplace_back(n(rng), n(rng), n(rng));
  for (int i = 0; i < 5; ++i) c.features.emplace_back(n(rng), n(rng));
  c.excluded = {0, 1, 0, 0, 0};
  c.kept = {0, 0, 1, 0, 0};
  const std::string path = TempPath("2d.json");
  ASSERT_TRUE(WriteSolverCheckpoint(Env::Default(), path, "in.g2o", c).ok());
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in.g2o");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSameControl(c, *read);
  EXPECT_EQ(read->poses, c.poses);
  EXPECT_EQ(read->features, c.features);
  // Not a 3-D checkpoint.
  StatusOr<core::SolverCheckpoint3d> as_3d = ReadSolverCheckpoint3d(path, "in.g2o");
  ASSERT_FALSE(as_3d.ok());
  EXPECT_NE(as_3d.status().ToString().find(path), std::string::npos);
  std::filesystem::remove(path);
}

// The per-feature arrays are formatted straight into the file (not through a
// JSON tree): random bit patterns, integral values, extremes and -0 read back
// bit for bit, over more than one 1 MiB append, and the file is plain JSON.
TEST(SolverCheckpoint, StreamedFeatureArraysReadBackBitForBit) {
  std::mt19937_64 rng(3);
  core::SolverCheckpoint c;
  FillControl(&c);
  c.poses.emplace_back(1.0, 2.0, 0.5);
  const double special[] = {0.0, -0.0, 1.0, -3.0, 1e22, 5e-324, 2.2250738585072014e-308,
                            1.7976931348623157e308, 0.1, 123456789.0};
  for (const double v : special) c.features.emplace_back(v, -v);
  while (c.features.size() < 100000) {
    double a, b;
    do {
      const uint64_t bits = rng();
      std::memcpy(&a, &bits, sizeof(a));
    } while (!std::isfinite(a));
    b = std::ldexp(static_cast<double>(rng() % 1000000), -static_cast<int>(rng() % 40));
    c.features.emplace_back(a, b);
  }
  c.excluded.assign(c.features.size(), 0);
  c.kept.assign(c.features.size(), 0);
  for (size_t i = 0; i < c.features.size(); i += 7) c.excluded[i] = 1;
  for (size_t i = 3; i < c.features.size(); i += 11) c.kept[i] = 1;
  const std::string path = TempPath("streamed.json");
  ASSERT_TRUE(WriteSolverCheckpoint(Env::Default(), path, "in", c).ok());
  ASSERT_GT(std::filesystem::file_size(path), size_t{1} << 21);
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSameControl(c, *read);
  ASSERT_EQ(read->features.size(), c.features.size());
  for (size_t i = 0; i < c.features.size(); ++i)
    for (int k = 0; k < 2; ++k)
      ASSERT_EQ(std::signbit(read->features[i][k]), std::signbit(c.features[i][k])) << i;
  EXPECT_EQ(read->features, c.features);
  std::ifstream in(path);
  const nlohmann::json json = nlohmann::json::parse(in);
  EXPECT_TRUE(json.at("features").at(4).is_number_float());  // 1.0 stays a float
  std::filesystem::remove(path);
}

TEST(SolverCheckpoint, SpatialStateReadsBackBitForBit) {
  std::mt19937 rng(2);
  std::normal_distribution<double> n(0.0, 1.0);
  core::SolverCheckpoint3d c;
  FillControl(&c);
  for (int i = 0; i < 20; ++i) {
    core::Pose3 pose;
    pose.t = Eigen::Vector3d(10 * n(rng), 10 * n(rng), n(rng));
    pose.q = core::ExpSO3(Eigen::Vector3d(n(rng), n(rng), n(rng)));
    c.poses.push_back(pose);
  }
  for (int i = 0; i < 4; ++i) c.features.emplace_back(n(rng), n(rng), n(rng));
  c.excluded = {0, 0, 1, 0};
  c.kept = {0, 0, 0, 0};
  const std::string path = TempPath("3d.json");
  ASSERT_TRUE(WriteSolverCheckpoint(Env::Default(), path, "in3d.g2o", c).ok());
  StatusOr<core::SolverCheckpoint3d> read = ReadSolverCheckpoint3d(path, "in3d.g2o");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSameControl(c, *read);
  ASSERT_EQ(read->poses.size(), c.poses.size());
  for (size_t i = 0; i < c.poses.size(); ++i) {
    EXPECT_EQ(read->poses[i].t, c.poses[i].t) << i;
    EXPECT_EQ(read->poses[i].q.coeffs(), c.poses[i].q.coeffs()) << i;
  }
  EXPECT_EQ(read->features, c.features);
  // Not a 2-D checkpoint, and not one of another input.
  EXPECT_FALSE(ReadSolverCheckpoint(path, "in3d.g2o").ok());
  EXPECT_FALSE(ReadSolverCheckpoint3d(path, "other.g2o").ok());
  std::filesystem::remove(path);
}

TEST(SolverCheckpoint, TruncatedSpatialPosesAreCorruption) {
  const std::string path = TempPath("bad3d.json");
  {
    std::ofstream out(path);
    out << SealJsonText(
        R"({"format":"graphslam-solver-checkpoint","version":1,"input":"x","dimension":3,)"
        R"("iterations":1,"trust_region_radius":1.0,"decrease_factor":2.0,"initial_chi2":1.0,)"
        R"("chi2":1.0,"converged":false,"termination":"","poses":[0,0,0,0,0,0],)"
        R"("features":[],"excluded":[],"kept":[]})");
  }
  StatusOr<core::SolverCheckpoint3d> read = ReadSolverCheckpoint3d(path, "x");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().ToString().find("multiple of 7"), std::string::npos)
      << read.status().ToString();
  EXPECT_NE(read.status().ToString().find(path), std::string::npos);
  std::filesystem::remove(path);
}

TEST(SolverCheckpoint, PcgStateReadsBackBitForBitAsVersion2) {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  core::SolverCheckpoint c;
  FillControl(&c);
  for (int i = 0; i < 4; ++i) c.poses.emplace_back(n(rng), n(rng), n(rng));
  c.pcg.present = true;
  c.pcg.eta = std::nextafter(0.0123, 1.0);
  c.pcg.previous_rhs_norm = 1.0 / 7.0;
  c.pcg.last_rhs_norm = 3.0 / 7.0;
  c.pcg.have_previous = true;
  for (int i = 0; i < 9; ++i) c.pcg.previous_x.push_back(n(rng) * 1e-7);
  c.pcg.forest_order = {2, 0, 1};
  c.pcg.forest_parent = {1, -1, 0};
  const std::string path = TempPath("pcg.json");
  ASSERT_TRUE(WriteSolverCheckpoint(Env::Default(), path, "in.g2o", c).ok());
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"version\":2"), std::string::npos) << text;
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in.g2o");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSameControl(c, *read);
  EXPECT_TRUE(read->pcg.present);
  EXPECT_EQ(read->pcg.eta, c.pcg.eta);
  EXPECT_EQ(read->pcg.previous_rhs_norm, c.pcg.previous_rhs_norm);
  EXPECT_EQ(read->pcg.last_rhs_norm, c.pcg.last_rhs_norm);
  EXPECT_EQ(read->pcg.have_previous, c.pcg.have_previous);
  EXPECT_EQ(read->pcg.previous_x, c.pcg.previous_x);
  EXPECT_EQ(read->pcg.forest_order, c.pcg.forest_order);
  EXPECT_EQ(read->pcg.forest_parent, c.pcg.forest_parent);
  std::filesystem::remove(path);
}

TEST(SolverCheckpoint, CholmodCheckpointStaysVersion1AndVersion1LoadsWithoutPcgState) {
  core::SolverCheckpoint c;
  FillControl(&c);
  c.poses.emplace_back(1.0, 2.0, 0.5);
  const std::string path = TempPath("v1.json");
  ASSERT_TRUE(WriteSolverCheckpoint(Env::Default(), path, "in.g2o", c).ok());
  std::ifstream in(path);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"version\":1"), std::string::npos) << text;
  EXPECT_EQ(text.find("pcg"), std::string::npos) << text;
  // A file as version 1 wrote it (before the pcg state existed).
  {
    std::ofstream out(path);
    out << SealJsonText(
        R"({"format":"graphslam-solver-checkpoint","version":1,"input":"x",)"
        R"("iterations":3,"trust_region_radius":2.5,"decrease_factor":2.0,"initial_chi2":9.0,)"
        R"("chi2":4.0,"converged":false,"termination":"","poses":[0,0,0,1,0,0],)"
        R"("features":[],"excluded":[],"kept":[]})");
  }
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "x");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->iterations, 3);
  EXPECT_FALSE(read->pcg.present);
  EXPECT_TRUE(read->pcg.previous_x.empty());
  EXPECT_TRUE(read->pcg.forest_order.empty());
  std::filesystem::remove(path);
}

TEST(SolverCheckpoint, MalformedPcgStateIsCorruption) {
  const std::string path = TempPath("badpcg.json");
  const std::string head =
      R"({"format":"graphslam-solver-checkpoint","version":2,"input":"x","iterations":1,)"
      R"("trust_region_radius":1.0,"decrease_factor":2.0,"initial_chi2":1.0,"chi2":1.0,)"
      R"("converged":false,"termination":"","poses":[0,0,0],"features":[],"excluded":[],)"
      R"("kept":[],"pcg":)";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {R"({"eta":0.1,"previous_rhs_norm":-1,"last_rhs_norm":-1,"have_previous":false,)"
       R"("previous_x":[],"forest_order":[0]})",
       "forest_parent"},
      {R"({"eta":0.0,"previous_rhs_norm":-1,"last_rhs_norm":-1,"have_previous":false,)"
       R"("previous_x":[],"forest_order":[],"forest_parent":[]})",
       "eta must be positive"},
      {R"({"eta":0.1,"previous_rhs_norm":-1,"last_rhs_norm":-1,"have_previous":false,)"
       R"("previous_x":[null],"forest_order":[],"forest_parent":[]})",
       "malformed field"},
      {R"({"eta":0.1,"previous_rhs_norm":-1,"last_rhs_norm":-1,"have_previous":false,)"
       R"("previous_x":[],"forest_order":[0,1],"forest_parent":[-1]})",
       "'pcg.forest_parent' 1"},
  };
  for (const auto& [pcg, message] : cases) {
    {
      std::ofstream out(path);
      out << SealJsonText(head + pcg + "}");
    }
    StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "x");
    ASSERT_FALSE(read.ok()) << pcg;
    EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
    EXPECT_NE(read.status().ToString().find(message), std::string::npos)
        << read.status().ToString();
    EXPECT_NE(read.status().ToString().find(path), std::string::npos);
  }
  std::filesystem::remove(path);
}

// The streaming solve's checkpoint (version 3): the feature estimates and
// flags in a binary feature file beside the JSON, which names it; writing the
// next generation removes the previous one.
TEST(SolverCheckpoint, FeatureFileReadsBackBitForBitAndReplacesTheOlderGeneration) {
  std::mt19937 rng(4);
  std::normal_distribution<double> n(0.0, 10.0);
  core::SolverCheckpoint c;
  FillControl(&c);
  c.pcg.present = true;
  c.pcg.eta = 0.5;
  for (int i = 0; i < 10; ++i) c.poses.emplace_back(n(rng), n(rng), n(rng));
  // More than one record (65536 features each).
  for (int i = 0; i < 70000; ++i) {
    c.features.emplace_back(n(rng), std::nextafter(n(rng), 1e9));
    c.excluded.push_back(i % 7 == 0);
    c.kept.push_back(i % 11 == 0 && i % 7 != 0);
  }
  const std::string path = TempPath("ff.json");
  ASSERT_TRUE(WriteSolverCheckpointWithFeatureFile(Env::Default(), path, "in", c).ok());
  EXPECT_TRUE(std::filesystem::exists(path + ".features.7.bin"));
  {
    std::ifstream in(path);
    const nlohmann::json json = nlohmann::json::parse(in);
    EXPECT_EQ(json["version"], 4);
    EXPECT_FALSE(json.contains("features")) << "per-feature JSON written";
    EXPECT_FALSE(json.contains("poses")) << "pose JSON written";
    EXPECT_EQ(json["state_file"], std::filesystem::path(path).filename().string() +
                                      ".state.7.bin");
    EXPECT_EQ(json["features_file"], std::filesystem::path(path).filename().string() +
                                         ".features.7.bin");
  }
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSameControl(c, *read);
  ASSERT_EQ(read->features.size(), c.features.size());
  for (size_t i = 0; i < c.features.size(); ++i)
    ASSERT_EQ(read->features[i], c.features[i]) << i;
  for (size_t i = 0; i < c.poses.size(); ++i) EXPECT_EQ(read->poses[i], c.poses[i]) << i;

  c.iterations = 8;
  c.features[5].x() += 1.0;
  ASSERT_TRUE(WriteSolverCheckpointWithFeatureFile(Env::Default(), path, "in", c).ok());
  EXPECT_FALSE(std::filesystem::exists(path + ".features.7.bin")) << "old generation kept";
  EXPECT_FALSE(std::filesystem::exists(path + ".state.7.bin")) << "old generation kept";
  read = ReadSolverCheckpoint(path, "in");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_EQ(read->iterations, 8);
  EXPECT_EQ(read->features[5], c.features[5]);
  std::filesystem::remove(path);
  std::filesystem::remove(path + ".features.8.bin");
  std::filesystem::remove(path + ".state.8.bin");
}

// A PCG state of the streaming solve's size class: the poses, the warm start
// and the forest span several records of the state file (65536 elements
// each) and read back bit for bit; the JSON holds none of them.
core::SolverCheckpoint LargePcgCheckpoint(int poses) {
  std::mt19937 rng(11);
  std::normal_distribution<double> n(0.0, 10.0);
  core::SolverCheckpoint c;
  FillControl(&c);
  for (int i = 0; i < poses; ++i) c.poses.emplace_back(n(rng), n(rng), std::nextafter(n(rng), 0.0));
  for (int i = 0; i < 20; ++i) {
    c.features.emplace_back(n(rng), n(rng));
    c.excluded.push_back(i == 3);
    c.kept.push_back(i == 5);
  }
  c.pcg.present = true;
  c.pcg.eta = std::nextafter(0.0123, 1.0);
  c.pcg.previous_rhs_norm = 1.0 / 7.0;
  c.pcg.last_rhs_norm = -1.0;
  c.pcg.have_previous = true;
  for (int i = 0; i < 3 * poses; ++i) c.pcg.previous_x.push_back(n(rng) * 1e-7);
  c.pcg.previous_x[c.pcg.previous_x.size() / 2] = -0.0;
  for (int i = 0; i < poses; ++i) {
    c.pcg.forest_order.push_back(poses - 1 - i);
    c.pcg.forest_parent.push_back(i == 0 ? -1 : (i - 1) / 2);
  }
  return c;
}

TEST(SolverCheckpoint, StateFileHoldsPosesAndPcgStateBitForBit) {
  const core::SolverCheckpoint c = LargePcgCheckpoint(70000);
  const std::string path = TempPath("state.json");
  ASSERT_TRUE(WriteSolverCheckpointWithFeatureFile(Env::Default(), path, "in", c).ok());
  EXPECT_LT(std::filesystem::file_size(path), 1000u) << "arrays written into the JSON";
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSameControl(c, *read);
  ASSERT_EQ(read->poses.size(), c.poses.size());
  for (size_t i = 0; i < c.poses.size(); ++i) ASSERT_EQ(read->poses[i], c.poses[i]) << i;
  EXPECT_TRUE(read->pcg.present);
  EXPECT_EQ(read->pcg.eta, c.pcg.eta);
  EXPECT_EQ(read->pcg.previous_rhs_norm, c.pcg.previous_rhs_norm);
  EXPECT_EQ(read->pcg.last_rhs_norm, c.pcg.last_rhs_norm);
  EXPECT_EQ(read->pcg.have_previous, c.pcg.have_previous);
  EXPECT_EQ(read->pcg.previous_x, c.pcg.previous_x);
  EXPECT_TRUE(std::signbit(read->pcg.previous_x[c.pcg.previous_x.size() / 2]));
  EXPECT_EQ(read->pcg.forest_order, c.pcg.forest_order);
  EXPECT_EQ(read->pcg.forest_parent, c.pcg.forest_parent);

  // A fresh (CHOLMOD) state stays absent.
  core::SolverCheckpoint cholmod = c;
  cholmod.pcg = core::PcgSolverState();
  ASSERT_TRUE(WriteSolverCheckpointWithFeatureFile(Env::Default(), path, "in", cholmod).ok());
  read = ReadSolverCheckpoint(path, "in");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  EXPECT_FALSE(read->pcg.present);
  EXPECT_TRUE(read->pcg.previous_x.empty());
  EXPECT_TRUE(read->pcg.forest_order.empty());
  std::filesystem::remove(path);
  std::filesystem::remove(path + ".features.7.bin");
  std::filesystem::remove(path + ".state.7.bin");
}

// Checkpoints of the previous format still load: version 3 (poses and the
// PCG state as JSON beside a feature file); a newer version than this build
// reads is NotSupported.
TEST(SolverCheckpoint, Version3CheckpointStillLoadsAndVersion5IsRefused) {
  const core::SolverCheckpoint c = LargePcgCheckpoint(5);
  const std::string path = TempPath("v3.json");
  ASSERT_TRUE(WriteSolverCheckpointWithFeatureFile(Env::Default(), path, "in", c).ok());
  nlohmann::json json;
  {
    std::ifstream in(path);
    json = nlohmann::json::parse(in);
  }
  // As version 3 wrote it.
  json["version"] = 3;
  json.erase("state_file");
  std::vector<double> poses;
  for (const auto& p : c.poses) poses.insert(poses.end(), {p.x(), p.y(), p.z()});
  json["poses"] = poses;
  json["pcg"] = {{"eta", c.pcg.eta},
                 {"previous_rhs_norm", c.pcg.previous_rhs_norm},
                 {"last_rhs_norm", c.pcg.last_rhs_norm},
                 {"have_previous", c.pcg.have_previous},
                 {"previous_x", c.pcg.previous_x},
                 {"forest_order", c.pcg.forest_order},
                 {"forest_parent", c.pcg.forest_parent}};
  std::filesystem::remove(path + ".state.7.bin");
  std::ofstream(path, std::ios::trunc) << SealJsonText(json.dump());
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in");
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ExpectSameControl(c, *read);
  EXPECT_EQ(read->poses, c.poses);
  EXPECT_EQ(read->pcg.previous_x, c.pcg.previous_x);
  EXPECT_EQ(read->pcg.forest_parent, c.pcg.forest_parent);

  json["version"] = 5;
  std::ofstream(path, std::ios::trunc) << SealJsonText(json.dump());
  read = ReadSolverCheckpoint(path, "in");
  ASSERT_FALSE(read.ok());
  EXPECT_TRUE(read.status().IsNotSupported()) << read.status().ToString();
  EXPECT_NE(read.status().message().find(path + ": checkpoint version 5; this build reads up to 4"),
            std::string::npos)
      << read.status().ToString();
  std::filesystem::remove(path);
  std::filesystem::remove(path + ".features.7.bin");
}

TEST(SolverCheckpoint, DamagedStateFileIsCorruptionNamingTheFileAndOffset) {
  const core::SolverCheckpoint c = LargePcgCheckpoint(10);
  const std::string path = TempPath("damaged_state.json");
  const std::string state = path + ".state.7.bin";
  ASSERT_TRUE(WriteSolverCheckpointWithFeatureFile(Env::Default(), path, "in", c).ok());
  const std::string bytes = testing::ReadWholeFile(state);
  const auto write = [&](const std::string& contents) {
    std::ofstream out(state, std::ios::binary | std::ios::trunc);
    out << contents;
  };
  const auto expect_error = [&](const std::string& what) {
    StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in");
    ASSERT_FALSE(read.ok()) << what;
    EXPECT_NE(read.status().message().find(state + what), std::string::npos)
        << read.status().ToString();
  };
  // Header 24 bytes, the summary record 9 + 51 bytes, then the poses record
  // at offset 84 (13 bytes of prefix, then 24 bytes per pose).
  std::string flipped = bytes;
  flipped[84 + 9 + 13 + 24 * 4 + 3] ^= 0x20;
  write(flipped);
  expect_error(": offset 84: record checksum mismatch");
  flipped = bytes;
  flipped[24 + 9 + 5] ^= 0x01;  // inside the summary
  write(flipped);
  expect_error(": offset 24: record checksum mismatch");
  write(bytes.substr(0, 200));  // truncated inside the poses record
  expect_error(": offset 84: truncated record");
  write(bytes.substr(0, bytes.size() - 3));  // truncated footer
  expect_error(": offset ");
  std::filesystem::remove(state);
  expect_error("");
  std::filesystem::remove(path);
  std::filesystem::remove(path + ".features.7.bin");
}

TEST(SolverCheckpoint, DamagedFeatureFileIsCorruptionNamingTheFileAndOffset) {
  core::SolverCheckpoint c;
  FillControl(&c);
  c.poses.emplace_back(1.0, 2.0, 0.5);
  for (int i = 0; i < 100; ++i) {
    c.features.emplace_back(i, -i);
    c.excluded.push_back(0);
    c.kept.push_back(0);
  }
  const std::string path = TempPath("damaged.json");
  const std::string features = path + ".features.7.bin";
  ASSERT_TRUE(WriteSolverCheckpointWithFeatureFile(Env::Default(), path, "in", c).ok());
  const std::string bytes = testing::ReadWholeFile(features);
  const auto write = [&](const std::string& contents) {
    std::ofstream out(features, std::ios::binary | std::ios::trunc);
    out << contents;
  };
  // The one data record starts after the 24-byte header.
  std::string flipped = bytes;
  flipped[24 + 9 + 12 + 8 * 31] ^= 0x01;
  write(flipped);
  StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in");
  ASSERT_FALSE(read.ok());
  EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
  EXPECT_NE(read.status().message().find(features + ": offset 24: record checksum mismatch"),
            std::string::npos)
      << read.status().ToString();

  write(bytes.substr(0, 500));  // truncated inside the record
  read = ReadSolverCheckpoint(path, "in");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().message().find(features + ": offset 24: truncated record"),
            std::string::npos)
      << read.status().ToString();

  write(bytes.substr(0, 10));  // truncated header
  read = ReadSolverCheckpoint(path, "in");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().message().find(features + ": offset 0: truncated header"),
            std::string::npos)
      << read.status().ToString();

  std::filesystem::remove(features);
  read = ReadSolverCheckpoint(path, "in");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().message().find(features), std::string::npos)
      << read.status().ToString();
  std::filesystem::remove(path);
}

}  // namespace
// Every checkpoint carries a crc32c seal over its bytes: a changed digit, a
// deleted entry or a missing seal is Corruption naming the file, never a
// resume from edited state (a job's interrupted stage resumes from one).
TEST(SolverCheckpoint, EditedOrUnsealedCheckpointIsCorruption) {
  core::SolverCheckpoint c;
  FillControl(&c);
  c.poses.emplace_back(1.0, 2.0, 0.5);
  c.poses.emplace_back(3.0, 2.0, 0.25);
  const std::string path = TempPath("sealed.json");
  ASSERT_TRUE(WriteSolverCheckpoint(Env::Default(), path, "in.g2o", c).ok());
  std::string text;
  {
    std::ifstream in(path);
    text.assign((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
  ASSERT_TRUE(ReadSolverCheckpoint(path, "in.g2o").ok());
  const size_t digit = text.find("\"chi2\":") + 7;
  ASSERT_TRUE(std::isdigit(static_cast<unsigned char>(text[digit]))) << text;
  std::string changed = text;
  changed[digit] = changed[digit] == '9' ? '8' : static_cast<char>(changed[digit] + 1);
  std::string unsealed = text.substr(0, text.rfind(",\"crc32c\"")) + "}";
  for (const auto& [name, bytes, message] :
       {std::tuple<std::string, std::string, std::string>{"digit", changed, "crc32c of its"},
        {"no seal", unsealed, "no crc32c seal"}}) {
    SCOPED_TRACE(name);
    std::ofstream(path, std::ios::trunc) << bytes;
    StatusOr<core::SolverCheckpoint> read = ReadSolverCheckpoint(path, "in.g2o");
    ASSERT_FALSE(read.ok());
    EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
    EXPECT_NE(read.status().ToString().find(path + ": " + message), std::string::npos)
        << read.status().ToString();
  }
  std::filesystem::remove(path);
}

}  // namespace graphslam::storage
