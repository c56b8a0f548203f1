// The 3-D iSAM reader: EDGE3 angle order and square-root information, POINT3,
// errors, and agreement with the g2o version of the same dataset.
#include <gtest/gtest.h>
#include "core/information_repair.h"
#include <Eigen/Cholesky>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>

#include "core/se3_lie.h"
#include "storage/dimension_detection.h"
#include "storage/g2o_3d_reader.h"
#include "storage/isam_3d_reader.h"
#include "tests/testing/datasets.h"

namespace graphslam::storage {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("gs3d_isam_" + std::to_string(::getpid()) + "_" + name))
                               .string();
  std::ofstream(path) << text;
  return path;
}

TEST(Isam3dReader, RollPitchYawAndSquareRootInformation) {
  const std::string path = WriteTemp(
      "a.txt",
      "EDGE3 0 1 1 2 3 0.1 0.2 0.3 10 0 0 0 0 0 10 0 0 0 0 10 0 0 0 100 0 5 100 0 25\n"
      "POINT3 1 4 0.5 0.6 0.7 2 1 0 2 0 2\n"
      "POINT3 0 4 1 1 1\n");
  StatusOr<core::Problem3d> read = ReadIsam3d(path);
  std::filesystem::remove(path);
  ASSERT_TRUE(read.ok()) << read.status().ToString();
  ASSERT_EQ(read->num_poses(), 2);
  ASSERT_EQ(read->relative_poses.size(), 1u);
  const core::RelativePose3Constraint& c = read->relative_poses[0];
  const Eigen::Matrix3d expected = (Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()) *
                                    Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                                    Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()))
                                       .toRotationMatrix();
  EXPECT_LT((c.z.rotation() - expected).norm(), 1e-15);
  EXPECT_EQ(c.z.t, Eigen::Vector3d(1, 2, 3));
  // Omega = K S^T S K, K = diag(1, 1, 1, 2, 2, 2) (angles -> vec(q)).
  EXPECT_DOUBLE_EQ(c.information(0, 0), 100.0);
  EXPECT_DOUBLE_EQ(c.information(3, 3), 4 * 10000.0);
  EXPECT_DOUBLE_EQ(c.information(3, 5), 4 * 500.0);
  EXPECT_DOUBLE_EQ(c.information(5, 5), 4 * (25.0 * 25.0 + 25.0));
  EXPECT_DOUBLE_EQ(c.information(0, 3), 0.0);
  EXPECT_EQ(read->pose_initialized[1], 0);
  ASSERT_EQ(read->observations.size(), 2u);
  EXPECT_EQ(read->num_features(), 1);
  EXPECT_DOUBLE_EQ(read->observations[0].information(0, 1), 2.0);
  EXPECT_DOUBLE_EQ(read->observations[0].information(1, 1), 1.0 + 4.0);
  EXPECT_EQ(read->observations[1].information, Eigen::Matrix3d::Identity());
}

TEST(Isam3dReader, ErrorsNameFileAndLine) {
  const std::string a = WriteTemp("bad1.txt", "EDGE3 0 1 1 2 3 0.1 0.2\n");
  StatusOr<core::Problem3d> read = ReadIsam3d(a);
  std::filesystem::remove(a);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().ToString().find(":1: EDGE3 has 8 fields"), std::string::npos)
      << read.status().ToString();
  const std::string b = WriteTemp("bad2.txt", "EDGE3 0 1 1 2 3 0 0 0\nEDGE2 1 2 0 0 0 1 0 0 1 0 1\n");
  read = ReadIsam3d(b);
  std::filesystem::remove(b);
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.status().ToString().find(":2: EDGE2 is a 2-D record"), std::string::npos)
      << read.status().ToString();
}

TEST(Isam3dReader, Sphere2500MatchesTheG2oVersionOfTheSameData) {
  GS_REQUIRE_DATASET("isam_datasets/sphere2500.txt");
  GS_REQUIRE_DATASET("sesync_posegraphs/sphere2500.g2o");
  const std::string isam_path = graphslam::testing::DatasetPath("isam_datasets/sphere2500.txt");
  StatusOr<bool> three_d = IsThreeDimensional(isam_path, InputFormat::kIsam);
  ASSERT_TRUE(three_d.ok());
  EXPECT_TRUE(*three_d);
  StatusOr<core::Problem3d> isam = ReadIsam3d(isam_path);
  StatusOr<core::Problem3d> g2o =
      ReadG2o3d(graphslam::testing::DatasetPath("sesync_posegraphs/sphere2500.g2o"));
  ASSERT_TRUE(isam.ok()) << isam.status().ToString();
  ASSERT_TRUE(g2o.ok());
  ASSERT_EQ(isam->num_poses(), 2500);
  ASSERT_EQ(isam->relative_poses.size(), g2o->relative_poses.size());
  // Same measurements edge by edge, matched by their pose ids (the two files
  // list the loop closures in different orders; they carry ~6 digits).
  std::map<std::pair<int64_t, int64_t>, const core::RelativePose3Constraint*> by_ids;
  for (const auto& b : g2o->relative_poses)
    by_ids[{g2o->pose_ids[b.from], g2o->pose_ids[b.to]}] = &b;
  double worst_t = 0, worst_r = 0;
  for (const auto& a : isam->relative_poses) {
    const auto it = by_ids.find({isam->pose_ids[a.from], isam->pose_ids[a.to]});
    ASSERT_NE(it, by_ids.end()) << isam->pose_ids[a.from] << " " << isam->pose_ids[a.to];
    const core::RelativePose3Constraint& b = *it->second;
    worst_t = std::max(worst_t, (a.z.t - b.z.t).norm());
    worst_r = std::max(worst_r, core::LogSO3(a.z.q.conjugate() * b.z.q).norm());
  }
  EXPECT_LT(worst_t, 1e-5);
  EXPECT_LT(worst_r, 1e-5);
}


// A singular square-root information: rejected naming the file and line, or
// Omega = S^T S (here diag(1, 1, 1, 1, 1, 0), rotation scaled to
// diag(1, 1, 1, 4, 4, 0)) repaired with the floor 1e-6 * 4 and counted. A zero
// POINT3 S gives Omega = 0, repaired to 1e-6 I.
TEST(Isam3dReader, RepairsSingularInformationOnlyWhenAsked) {
  const std::string path = WriteTemp(
      "singular3.txt",
      "EDGE3 0 1 1 0 0 0 0 0 1 0 0 0 0 0  1 0 0 0 0  1 0 0 0  1 0 0  1 0  0\n"
      "POINT3 1 5 1 0 0 0 0 0 0 0 0\n");
  const Status rejected = ReadIsam3d(path).status();
  EXPECT_TRUE(rejected.IsCorruption());
  EXPECT_NE(rejected.message().find("singular3.txt:1: EDGE3 square-root information"),
            std::string::npos)
      << rejected.message();
  core::InformationRepairs repairs;
  StatusOr<core::Problem3d> problem = ReadIsam3d(path, &repairs);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(repairs.count, 2);
  EXPECT_EQ(repairs.first_lines, (std::vector<int32_t>{1, 2}));
  const core::Matrix6d& pose = problem->relative_poses[0].information;
  EXPECT_EQ(Eigen::LLT<core::Matrix6d>(pose).info(), Eigen::Success);
  core::Matrix6d expected = core::Matrix6d::Zero();
  expected.diagonal() << 1, 1, 1, 4, 4, 4e-6;
  EXPECT_LT((pose - expected).cwiseAbs().maxCoeff(), 1e-15) << pose;
  const Eigen::Matrix3d& point = problem->observations[0].information;
  EXPECT_LT((point - 1e-6 * Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-18) << point;
}

}  // namespace
}  // namespace graphslam::storage
