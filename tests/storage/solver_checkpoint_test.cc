// Solver checkpoints on disk (storage/solver_checkpoint.h): 2-D and 3-D
// states read back bit for bit; a checkpoint of the other dimension, of
// another input, or with a truncated pose array is refused with the path.
#include "storage/solver_checkpoint.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "core/se3_lie.h"

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
    out << R"({"format":"graphslam-solver-checkpoint","version":1,"input":"x","dimension":3,)"
        << R"("iterations":1,"trust_region_radius":1.0,"decrease_factor":2.0,"initial_chi2":1.0,)"
        << R"("chi2":1.0,"converged":false,"termination":"","poses":[0,0,0,0,0,0],)"
        << R"("features":[],"excluded":[],"kept":[]})";
  }
  StatusOr<core::SolverCheckpoint3d> read = ReadSolverCheckpoint3d(path, "x");
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().ToString().find("multiple of 7"), std::string::npos)
      << read.status().ToString();
  EXPECT_NE(read.status().ToString().find(path), std::string::npos);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace graphslam::storage
