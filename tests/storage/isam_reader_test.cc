#include "storage/isam_reader.h"

#include <gtest/gtest.h>
#include <Eigen/Cholesky>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>

#include "tests/testing/datasets.h"

namespace graphslam::storage {
namespace {

using testing::DatasetPath;

std::string WriteTemp(const std::string& name, const std::string& contents) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("graphslam_isam_reader_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << contents;
  return path;
}

Status ReadError(const std::string& contents) {
  const auto problem = ReadIsam(WriteTemp("bad.txt", contents));
  EXPECT_FALSE(problem.ok());
  return problem.ok() ? Status::Ok() : problem.status();
}

TEST(IsamReader, VictoriaParkCounts) {
  GS_REQUIRE_DATASET("isam_datasets/victoriaPark.txt");
  const auto problem = ReadIsam(DatasetPath("isam_datasets/victoriaPark.txt"));
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  // README.isam-data.txt: 6969 poses, 151 landmarks, 3640 landmark
  // measurements, 6968 odometry constraints.
  EXPECT_EQ(problem->num_poses(), 6969);
  EXPECT_EQ(problem->num_features(), 151);
  EXPECT_EQ(problem->observations.size(), 3640u);
  EXPECT_EQ(problem->relative_poses.size(), 6968u);
  for (uint8_t initialized : problem->pose_initialized) ASSERT_EQ(initialized, 0);
  // Pose ids and landmark ids are disjoint in this file.
  std::set<int64_t> pose_ids(problem->pose_ids.begin(), problem->pose_ids.end());
  for (int64_t id : problem->feature_ids) ASSERT_EQ(pose_ids.count(id), 0u) << id;
  // Square-root information: odometry R = diag(100, 500, 500) -> R^T R.
  const Eigen::Matrix3d& odometry = problem->relative_poses[0].information;
  EXPECT_DOUBLE_EQ(odometry(0, 0), 1e4);
  EXPECT_DOUBLE_EQ(odometry(1, 1), 2.5e5);
  EXPECT_DOUBLE_EQ(odometry(2, 2), 2.5e5);
  const core::Observation& first = problem->observations[0];
  EXPECT_EQ(first.line, 5);
  EXPECT_EQ(first.kind, core::ObservationKind::kPointXY);
  EXPECT_EQ(problem->pose_ids[first.pose], 4);
  EXPECT_EQ(problem->feature_ids[first.feature], 5);
  EXPECT_NEAR(first.information(0, 0), 1.581139 * 1.581139, 1e-12);
}

TEST(IsamReader, ManhattanAndCityCounts) {
  GS_REQUIRE_DATASET("isam_datasets/manhattanOlson3500.txt");
  GS_REQUIRE_DATASET("isam_datasets/city10000.txt");
  const auto manhattan = ReadIsam(DatasetPath("isam_datasets/manhattanOlson3500.txt"));
  ASSERT_TRUE(manhattan.ok()) << manhattan.status().ToString();
  EXPECT_EQ(manhattan->num_poses(), 3500);
  EXPECT_EQ(manhattan->relative_poses.size(), 5598u);
  const auto city = ReadIsam(DatasetPath("isam_datasets/city10000.txt"));  // EDGE2 lines
  ASSERT_TRUE(city.ok()) << city.status().ToString();
  EXPECT_EQ(city->num_poses(), 10000);
  EXPECT_EQ(city->relative_poses.size(), 20687u);
}

TEST(IsamReader, ThreeDimensionalIsNotSupported) {
  GS_REQUIRE_DATASET("isam_datasets/sphere400.txt");
  const auto problem = ReadIsam(DatasetPath("isam_datasets/sphere400.txt"));
  ASSERT_TRUE(problem.status().IsNotSupported());
  EXPECT_EQ(problem.status().message(),
            "sphere400.txt:1: EDGE3 is a 3-D record; expected a 2-D file (3-D is not supported)");
}

TEST(IsamReader, SquareRootInformationWithOffDiagonal) {
  const auto problem = ReadIsam(WriteTemp("ok.txt", "ODOMETRY 0 1 1 2 3 1 2 3 4 5 6\n"));
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  Eigen::Matrix3d r;
  r << 1, 2, 3, 0, 4, 5, 0, 0, 6;
  EXPECT_EQ(problem->relative_poses[0].information, r.transpose() * r);
}

TEST(IsamReader, RejectsMalformedInput) {
  EXPECT_EQ(ReadError("ODOMETRY 0 1 1 0 0 1 0 0 1 0\n").message(),
            "bad.txt:1: ODOMETRY has 11 fields; expected 12");
  EXPECT_EQ(ReadError("LANDMARK 0 5 1.0 abc 1 0 1\n").message(),
            "bad.txt:1: LANDMARK field 5 (measurement) is 'abc'; expected a number");
  EXPECT_EQ(ReadError("LANDMARK 0 5 1.0 2.0 1 0 NaN\n").message(),
            "bad.txt:1: LANDMARK field 8 (sqrt information) is 'NaN'; expected a finite number");
  EXPECT_EQ(ReadError("ODOMETRY 0 1 1 0 0 1 0 0 0 0 1\n").message(),
            "bad.txt:1: ODOMETRY square-root information [1 0 0 0 0 1] is singular; expected an "
            "upper-triangular R with a non-zero diagonal (sxx sxy sxt syy syt stt)");
  const Status unknown = ReadError("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nVERTEX_SE2 0 0 0 0\n");
  EXPECT_TRUE(unknown.IsNotSupported());
  EXPECT_EQ(unknown.message(),
            "bad.txt:2: unknown tag 'VERTEX_SE2'; expected ODOMETRY, EDGE2 or LANDMARK");
  EXPECT_EQ(ReadError("EDGE2 3 3 1 0 0 1 0 0 1 0 1\n").message(),
            "bad.txt:1: EDGE2 connects pose 3 to itself; expected two distinct poses");
}


// A singular R (a zero on the diagonal): rejected naming the file and line,
// or Omega = R^T R repaired with the eigenvalue floor and counted.
// R = diag(10, 10, 0): Omega = diag(100, 100, 0) -> diag(100, 100, 1e-4);
// LANDMARK R = diag(2, 0): Omega = diag(4, 0) -> diag(4, 4e-6).
TEST(IsamReader, RepairsSingularInformationOnlyWhenAsked) {
  const std::string path = WriteTemp("singular.txt",
                                     "ODOMETRY 0 1 1 0 0 10 0 0 10 0 0\n"
                                     "LANDMARK 1 5 1 1 2 0 0\n");
  const Status rejected = ReadIsam(path).status();
  EXPECT_TRUE(rejected.IsCorruption());
  EXPECT_NE(rejected.message().find("singular.txt:1: ODOMETRY square-root information"),
            std::string::npos)
      << rejected.message();
  core::InformationRepairs repairs;
  StatusOr<core::Problem2d> problem = ReadIsam(path, &repairs);
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(repairs.count, 2);
  EXPECT_EQ(repairs.first_lines, (std::vector<int32_t>{1, 2}));
  const Eigen::Matrix3d& odometry = problem->relative_poses[0].information;
  EXPECT_EQ(Eigen::LLT<Eigen::Matrix3d>(odometry).info(), Eigen::Success);
  EXPECT_LT((odometry - Eigen::Vector3d(100, 100, 1e-4).asDiagonal().toDenseMatrix())
                .cwiseAbs()
                .maxCoeff(),
            1e-15)
      << odometry;
  const Eigen::Matrix2d& landmark = problem->observations[0].information;
  EXPECT_LT((landmark - Eigen::Vector2d(4, 4e-6).asDiagonal().toDenseMatrix()).cwiseAbs().maxCoeff(),
            1e-18)
      << landmark;
}

}  // namespace
}  // namespace graphslam::storage
