#include "storage/features_csv_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace graphslam::storage {
namespace {

std::string Slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

TEST(FeaturesCsvWriter, WritesIdsPositionsCountsAndExclusions) {
  core::Problem2d problem;
  problem.AddPose(0, core::Pose2::Zero(), true, 0);
  problem.AddFeature(5, core::Point2(1.5, -2.0), true);
  problem.AddFeature(9, core::Point2(0.1, 3.0), true);
  for (int k = 0; k < 3; ++k) {
    core::Observation observation;
    observation.pose = 0;
    observation.feature = k == 2 ? 1 : 0;
    problem.observations.push_back(observation);
  }
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("graphslam_features_" + std::to_string(::getpid()) + ".csv"))
                               .string();
  const std::vector<uint8_t> excluded = {0, 1};
  ASSERT_TRUE(WriteFeaturesCsv(problem, path, &excluded).ok());
  EXPECT_EQ(Slurp(path),
            "id,x,y,observations,excluded\n"
            "5,1.5,-2,2,0\n"
            "9,0.10000000000000001,3,1,1\n");
  ASSERT_TRUE(WriteFeaturesCsv(problem, path).ok());
  EXPECT_NE(Slurp(path).find("9,0.10000000000000001,3,1,0\n"), std::string::npos);
  const std::vector<uint8_t> wrong_size = {0};
  const Status status = WriteFeaturesCsv(problem, path, &wrong_size);
  EXPECT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(status.message(),
            "writing " + path + ": excluded has 1 entries; expected 2 (one per feature)");
  std::filesystem::remove(path);
}

// 3-D: the same rows with a z column; an observation of a feature that does
// not exist is rejected before anything is written.
TEST(FeaturesCsvWriter, Writes3dPointsWithAZColumn) {
  core::Problem3d problem;
  problem.AddPose(0, core::Pose3(), true, 0);
  problem.AddFeature(7, core::Point3(1.5, -2.0, 0.25), true);
  problem.AddFeature(3, core::Point3(0.1, 3.0, -4.0), true);
  for (int k = 0; k < 3; ++k) {
    core::Point3Observation observation;
    observation.pose = 0;
    observation.feature = k == 0 ? 1 : 0;
    problem.observations.push_back(observation);
  }
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("graphslam_features_3d_" + std::to_string(::getpid()) + ".csv"))
                               .string();
  const std::vector<uint8_t> excluded = {1, 0};
  ASSERT_TRUE(WriteFeaturesCsv(problem, path, &excluded).ok());
  EXPECT_EQ(Slurp(path),
            "id,x,y,z,observations,excluded\n"
            "7,1.5,-2,0.25,2,1\n"
            "3,0.10000000000000001,3,-4,1,0\n");
  std::filesystem::remove(path);
  problem.observations[2].feature = 2;
  const Status status = WriteFeaturesCsv(problem, path);
  EXPECT_TRUE(status.IsInvalidArgument());
  EXPECT_EQ(status.message(), "writing " + path +
                                  ": observations[2].feature is 2; expected an index in [0, 2) "
                                  "(num_features)");
  EXPECT_FALSE(std::filesystem::exists(path));
}

}  // namespace
}  // namespace graphslam::storage
