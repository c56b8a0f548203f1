#include "storage/format_detection.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "tests/testing/datasets.h"

namespace graphslam::storage {
namespace {

using testing::DatasetPath;

std::string WriteTemp(const std::string& name, const std::string& contents) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("graphslam_format_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / name).string();
  std::ofstream(path) << contents;
  return path;
}

TEST(FormatDetection, RealDatasets) {
  GS_REQUIRE_DATASET("victoria_park/victoriaPark-full.g2o");
  GS_REQUIRE_DATASET("isam_datasets/victoriaPark.txt");
  GS_REQUIRE_DATASET("mrclam_dataset1_sampled50hz");
  GS_REQUIRE_DATASET("sesync_posegraphs/CSAIL.g2o");
  EXPECT_EQ(*DetectInputFormat(DatasetPath("victoria_park/victoriaPark-full.g2o")),
            InputFormat::kG2o);
  EXPECT_EQ(*DetectInputFormat(DatasetPath("sesync_posegraphs/CSAIL.g2o")), InputFormat::kG2o);
  EXPECT_EQ(*DetectInputFormat(DatasetPath("isam_datasets/victoriaPark.txt")),
            InputFormat::kIsam);
  EXPECT_EQ(*DetectInputFormat(DatasetPath("isam_datasets/city10000.txt")), InputFormat::kIsam);
  EXPECT_EQ(*DetectInputFormat(DatasetPath("mrclam_dataset1_sampled50hz")),
            InputFormat::kMrclam);
}

TEST(FormatDetection, SmallFilesAndComments) {
  EXPECT_EQ(*DetectInputFormat(WriteTemp("a.log", "# c\n\nGRAPHSLAM_LOG 1\n")),
            InputFormat::kNative);
  EXPECT_EQ(*DetectInputFormat(WriteTemp("a.g2o", "# c\nFIX 0\n")), InputFormat::kG2o);
  EXPECT_EQ(*DetectInputFormat(WriteTemp("p.g2o", "PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n")),
            InputFormat::kG2o);
  EXPECT_EQ(*DetectInputFormat(WriteTemp("b.txt", "LANDMARK 0 1 1 1 1 0 1\n")),
            InputFormat::kIsam);
  const auto unknown = DetectInputFormat(WriteTemp("c.txt", "# c\nHELLO world\n"));
  ASSERT_TRUE(unknown.status().IsNotSupported());
  EXPECT_EQ(unknown.status().message(),
            "c.txt:2: first record 'HELLO' matches no known format; expected VERTEX_*/EDGE_*/PARAMS_*/FIX "
            "(g2o), ODOMETRY/EDGE2/LANDMARK (iSAM), VERTEX2/VERTEX3 (TORO .graph) or GRAPHSLAM_LOG "
            "(native log)");
  EXPECT_TRUE(DetectInputFormat(WriteTemp("d.txt", "# only\n")).status().IsCorruption());
  EXPECT_TRUE(DetectInputFormat("/nonexistent/x.g2o").status().IsNotFound());
  EXPECT_TRUE(DetectInputFormat(std::filesystem::temp_directory_path().string())
                  .status()
                  .IsNotSupported());
}

TEST(FormatDetection, ParseNamesRoundTrip) {
  for (InputFormat format : {InputFormat::kG2o, InputFormat::kIsam, InputFormat::kMrclam,
                             InputFormat::kNative, InputFormat::kToro}) {
    EXPECT_EQ(*ParseInputFormat(InputFormatName(format)), format);
  }
  EXPECT_EQ(ParseInputFormat("graph").status().message(),
            "input format 'graph'; expected auto, g2o, isam, mrclam, native or toro");
}

TEST(FormatDetection, ReadProblemDispatches) {
  const std::string path = WriteTemp("e.g2o", "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n"
                                              "EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n");
  const auto problem = ReadProblem(path, *DetectInputFormat(path), MrclamOptions());
  ASSERT_TRUE(problem.ok()) << problem.status().ToString();
  EXPECT_EQ(problem->num_poses(), 2);
  EXPECT_FALSE(ReadProblem(path, InputFormat::kIsam, MrclamOptions()).ok());
}

}  // namespace
}  // namespace graphslam::storage
