#include "storage/tum_writer.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace graphslam::storage {
namespace {

TEST(TumWriter, WritesStampsOrIndicesAndYawQuaternions) {
  core::Problem2d problem;
  problem.AddPose(0, core::Pose2(1.0, 2.0, 0.0), true, 0, 12.5);
  problem.AddPose(1, core::Pose2(-1.0, 0.5, M_PI / 2), true, 0);  // NaN stamp
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("graphslam_tum_" + std::to_string(::getpid()) + ".txt"))
                               .string();
  ASSERT_TRUE(WriteTum(problem, path).ok());
  std::ifstream in(path);
  std::string header, first, second;
  std::getline(in, header);
  std::getline(in, first);
  std::getline(in, second);
  EXPECT_EQ(header, "# timestamp x y z qx qy qz qw");
  EXPECT_EQ(first, "12.5 1 2 0 0 0 0 1");
  std::istringstream fields(second);
  double t, x, y, z, qx, qy, qz, qw;
  fields >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
  EXPECT_EQ(t, 1.0);  // the pose index
  EXPECT_EQ(x, -1.0);
  EXPECT_NEAR(qz, std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(qw, std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(2.0 * std::atan2(qz, qw), M_PI / 2, 1e-15);
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace graphslam::storage
