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

}  // namespace
}  // namespace graphslam::storage
