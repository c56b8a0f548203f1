// The TORO / GTSAM .graph reader (storage/toro_reader.h): both example files
// of GTSAM, the information conventions on hand-made records, detection, and
// the errors.
#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "storage/dimension_detection.h"
#include "storage/format_detection.h"
#include "storage/isam_3d_reader.h"
#include "storage/toro_reader.h"
#include "tests/testing/datasets.h"

namespace graphslam::storage {
namespace {

std::string WriteTemp(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("gs_toro_" + std::to_string(::getpid()) + "_" + name))
                               .string();
  std::ofstream(path) << text;
  return path;
}

TEST(ToroReader, GtsamW100) {
  GS_REQUIRE_DATASET("gtsam_examples/w100.graph");
  const std::string path = testing::DatasetPath("gtsam_examples/w100.graph");
  ASSERT_EQ(*DetectInputFormat(path), InputFormat::kToro);
  ASSERT_FALSE(*IsThreeDimensional(path, InputFormat::kToro));
  StatusOr<core::Problem2d> problem = ReadToro(path);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->num_poses(), 100);
  EXPECT_EQ(problem->relative_poses.size(), 300u);  // the 40 EQUIV lines add nothing
  EXPECT_TRUE(problem->observations.empty());
  for (int32_t i = 0; i < problem->num_poses(); ++i) EXPECT_EQ(problem->pose_initialized[i], 1);
  // VERTEX2 1 0.995595 0.0837204 0.0146728
  EXPECT_EQ(problem->pose_ids[1], 1);
  EXPECT_DOUBLE_EQ(problem->poses[1].x(), 0.995595);
  EXPECT_DOUBLE_EQ(problem->poses[1].z(), 0.0146728);
  // EDGE2 1 0 -0.99879 0.0417574 -0.00818381 1 0 1 1 0 0: the first edge.
  const core::RelativePoseConstraint& e = problem->relative_poses[0];
  EXPECT_EQ(problem->pose_ids[e.from], 1);
  EXPECT_EQ(problem->pose_ids[e.to], 0);
  EXPECT_DOUBLE_EQ(e.z.x(), -0.99879);
  EXPECT_TRUE(e.information.isApprox(Eigen::Matrix3d::Identity()));
}

TEST(ToroReader, GtsamExampleWithBearingRange) {
  GS_REQUIRE_DATASET("gtsam_examples/example.graph");
  const std::string path = testing::DatasetPath("gtsam_examples/example.graph");
  ASSERT_EQ(*DetectInputFormat(path), InputFormat::kToro);
  StatusOr<core::Problem2d> problem = ReadProblem(path, InputFormat::kToro, {});
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->num_poses(), 95);
  EXPECT_EQ(problem->relative_poses.size(), 94u);
  EXPECT_EQ(problem->observations.size(), 422u);
  EXPECT_EQ(problem->num_features(), 24);
  // BR 0 144 0.185182458717 9.13212526936 0.0349 0.1
  const core::Observation& o = problem->observations[0];
  EXPECT_EQ(o.kind, core::ObservationKind::kRangeBearing);
  EXPECT_EQ(problem->pose_ids[o.pose], 0);
  EXPECT_EQ(problem->feature_ids[o.feature], 144);
  EXPECT_DOUBLE_EQ(o.z(0), 9.13212526936);   // range
  EXPECT_DOUBLE_EQ(o.z(1), 0.185182458717);  // bearing
  EXPECT_DOUBLE_EQ(o.information(0, 0), 1.0 / (0.1 * 0.1));
  EXPECT_DOUBLE_EQ(o.information(1, 1), 1.0 / (0.0349 * 0.0349));
  EXPECT_EQ(o.information(0, 1), 0.0);
  EXPECT_EQ(problem->feature_initialized[o.feature], 0);  // placed from first sight
}

TEST(ToroReader, InformationInToroOrder) {
  // I11 I12 I22 I33 I13 I23 = 10 1 20 30 2 3
  const std::string path = WriteTemp(
      "order.graph", "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\nEDGE2 0 1 1 0 0 10 1 20 30 2 3\n");
  StatusOr<core::Problem2d> problem = ReadToro(path);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  Eigen::Matrix3d expected;
  expected << 10, 1, 2, 1, 20, 3, 2, 3, 30;
  EXPECT_EQ(problem->relative_poses[0].information, expected);
}

TEST(ToroReader, ThreeDimensionalRecords) {
  // Information diag(1, 2, 3, 4, 5, 6) over (x, y, z, roll, pitch, yaw).
  const std::string path = WriteTemp(
      "three.graph",
      "VERTEX3 0 0 0 0 0 0 0\nVERTEX3 1 1 2 3 0.1 0.2 0.3\n"
      "EDGE3 0 1 1 2 3 0.1 0.2 0.3 1 0 0 0 0 0 2 0 0 0 0 3 0 0 0 4 0 0 5 0 6\n");
  ASSERT_EQ(*DetectInputFormat(path), InputFormat::kToro);
  ASSERT_TRUE(*IsThreeDimensional(path, InputFormat::kToro));
  StatusOr<core::Problem3d> problem = ReadToro3d(path);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  ASSERT_EQ(problem->num_poses(), 2);
  EXPECT_TRUE(problem->poses[1].q.isApprox(QuaternionFromRollPitchYaw(0.1, 0.2, 0.3)));
  EXPECT_TRUE(problem->poses[1].t.isApprox(Eigen::Vector3d(1, 2, 3)));
  const core::RelativePose3Constraint& c = problem->relative_poses[0];
  EXPECT_TRUE(c.z.q.isApprox(QuaternionFromRollPitchYaw(0.1, 0.2, 0.3)));
  // Rotation rows and columns x2 each: angles -> vec(q) = angles / 2.
  core::Matrix6d expected = core::Matrix6d::Zero();
  expected.diagonal() << 1, 2, 3, 16, 20, 24;
  EXPECT_TRUE(c.information.isApprox(expected)) << c.information;
}

TEST(ToroReader, PosesWithoutVertexAreUninitialized) {
  const std::string path = WriteTemp("edges.graph", "EQUIV 0 1\nEDGE2 0 1 1 0 0 1 0 1 1 0 0\n");
  ASSERT_EQ(*DetectInputFormat(path), InputFormat::kToro);
  StatusOr<core::Problem2d> problem = ReadToro(path);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->num_poses(), 2);
  EXPECT_EQ(problem->pose_initialized[0], 0);
}

struct BadCase {
  const char* text;
  const char* message;
};

class ToroReaderErrors : public ::testing::TestWithParam<BadCase> {};

TEST_P(ToroReaderErrors, NameFileLineAndExpectation) {
  const std::string path = WriteTemp("bad.graph", GetParam().text);
  StatusOr<core::Problem2d> problem = ReadToro(path);
  ASSERT_FALSE(problem.ok());
  EXPECT_NE(problem.status().ToString().find(GetParam().message), std::string::npos)
      << problem.status().ToString();
}

INSTANTIATE_TEST_SUITE_P(
    Cases, ToroReaderErrors,
    ::testing::Values(
        BadCase{"VERTEX2 0 0 0 0\nEDGE2 0 1 1 0 0 1 0 1 1 0\n",
                "bad.graph:2: EDGE2 has 11 fields; expected 12"},
        BadCase{"VERTEX2 0 0 0 0\nEDGE2 0 1 1 0 0 1 2 1 1 0 0\n",
                "bad.graph:2: EDGE2 information [1 2 1 1 0 0] is not positive definite"},
        BadCase{"VERTEX2 0 0 0 0\nVERTEX2 0 1 0 0\n", "bad.graph:2: VERTEX2 defines pose 0 again"},
        BadCase{"VERTEX2 0 0 0 0\nEDGE2 0 0 1 0 0 1 0 1 1 0 0\n",
                "bad.graph:2: EDGE2 connects pose 0 to itself"},
        BadCase{"VERTEX2 0 0 0 0\nBR 0 7 0.1 5 0 0.1\n", "bad.graph:2: BR sigmas"},
        BadCase{"VERTEX2 0 0 0 abc\n", "bad.graph:1: VERTEX2 field 5 (estimate) is 'abc'"},
        BadCase{"VERTEX2 0 0 0 0\nVERTEX3 1 0 0 0 0 0 0\n",
                "bad.graph:2: VERTEX3 is a 3-D record in a 2-D file"},
        BadCase{"VERTEX2 0 0 0 0\nLANDMARK 0 1 2 3\n", "bad.graph:2: unknown record 'LANDMARK'"}));

TEST(ToroReader, UnknownFormatNameListsToroAndAuto) {
  StatusOr<InputFormat> format = ParseInputFormat("graph");
  ASSERT_FALSE(format.ok());
  EXPECT_NE(format.status().ToString().find("expected auto, g2o, isam, mrclam, native or toro"),
            std::string::npos);
  EXPECT_EQ(*ParseInputFormat("toro"), InputFormat::kToro);
}

// An EDGE2 information that is not positive definite: rejected naming the
// line, or, with repair on (core/information_repair.h), repaired and counted.
TEST(ToroReader, RepairsIndefiniteInformationOnlyWhenAsked) {
  const std::string path = WriteTemp("indefinite.graph",
                                     "VERTEX2 0 0 0 0\nVERTEX2 1 1 0 0\n"
                                     "EDGE2 0 1 1 0 0 1 0 1 1 0 0\n"
                                     "EDGE2 0 1 1 0 0 1 2 1 1 0 0\n");
  const Status rejected = ReadToro(path).status();
  EXPECT_TRUE(rejected.IsCorruption());
  EXPECT_NE(rejected.message().find(":4: EDGE2 information"), std::string::npos)
      << rejected.message();
  core::InformationRepairs repairs;
  StatusOr<core::Problem2d> problem = ReadToro(path, &repairs);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(repairs.count, 1);
  EXPECT_EQ(repairs.first_lines, (std::vector<int32_t>{4}));
  EXPECT_EQ(problem->relative_poses[0].information, Eigen::Matrix3d::Identity());
  EXPECT_GT(problem->relative_poses[1].information.determinant(), 0.0);
}


// An EDGE3 information that is not positive definite: rejected naming the
// file and line, or repaired and counted. diag(1, 1, 1, 1, 1, -2): the floor
// is 1e-6 * 2, so yaw gets 2e-6 and, after the x2 scaling of the rotation
// rows and columns (the header), 8e-6; the rest is unchanged (roll: 1 * 4).
TEST(ToroReader, RepairsIndefinite3dInformationOnlyWhenAsked) {
  const std::string path = WriteTemp("indefinite3.graph",
                                     "VERTEX3 0 0 0 0 0 0 0\nVERTEX3 1 1 0 0 0 0 0\n"
                                     "EDGE3 0 1 1 0 0 0 0 0 "
                                     "1 0 0 0 0 0  1 0 0 0 0  1 0 0 0  1 0 0  1 0  -2\n");
  const Status rejected = ReadToro3d(path).status();
  EXPECT_TRUE(rejected.IsCorruption());
  EXPECT_NE(rejected.message().find("indefinite3.graph:3: EDGE3 information"), std::string::npos)
      << rejected.message();
  core::InformationRepairs repairs;
  StatusOr<core::Problem3d> problem = ReadToro3d(path, &repairs);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(repairs.count, 1);
  EXPECT_EQ(repairs.first_lines, (std::vector<int32_t>{3}));
  const core::Matrix6d& information = problem->relative_poses[0].information;
  EXPECT_EQ(Eigen::LLT<core::Matrix6d>(information).info(), Eigen::Success);
  core::Matrix6d expected = core::Matrix6d::Zero();
  expected.diagonal() << 1, 1, 1, 4, 4, 8e-6;
  EXPECT_LT((information - expected).cwiseAbs().maxCoeff(), 1e-15) << information;
}

}  // namespace
}  // namespace graphslam::storage
