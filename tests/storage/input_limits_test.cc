// Issue 22, defects 6 and 7 at read time: numbers beyond the documented
// magnitude bounds (storage/internal/text_reader.h) are errors naming
// file:line and the expected range in every reader (g2o 2-D / 3-D, iSAM 2-D /
// 3-D, MRCLAM, native log); a line longer than 1 MiB is an error, found
// without buffering the whole line (a .zst holding one 1 GB line); a zstd
// stream that inflates beyond 1024x its compressed size is an error.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "storage/compressed_file.h"
#include "storage/env.h"
#include "storage/g2o_3d_reader.h"
#include "storage/g2o_reader.h"
#include "storage/isam_3d_reader.h"
#include "storage/isam_reader.h"
#include "storage/mrclam_reader.h"
#include "storage/native_log_reader.h"

namespace graphslam::storage {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

class InputLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("graphslam_input_limits_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Write(const std::string& name, const std::string& contents) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << contents;
    return path;
  }
  // `chunk` appended `times` times, as one zstd frame.
  std::string WriteZstd(const std::string& name, const std::string& head,
                        const std::string& chunk, int times) const {
    const std::string path = (dir_ / name).string();
    auto file = Env::Default()->NewWritableFile(path);
    EXPECT_TRUE(file.ok());
    ZstdWriter writer(file->get(), 3);
    EXPECT_TRUE(writer.Append(head).ok());
    for (int k = 0; k < times; ++k) EXPECT_TRUE(writer.Append(chunk).ok());
    EXPECT_TRUE(writer.Finish().ok());
    EXPECT_TRUE((*file)->Close().ok());
    return path;
  }
  fs::path dir_;
};

template <typename T>
std::string ErrorOf(const StatusOr<T>& read) {
  EXPECT_FALSE(read.ok());
  if (read.ok()) return "";
  EXPECT_TRUE(read.status().IsCorruption()) << read.status().ToString();
  return read.status().message();
}

TEST_F(InputLimitsTest, G2oEstimateMeasurementAndInformationBounds) {
  const std::string poses = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\n";
  EXPECT_EQ(ErrorOf(ReadG2o(Write("a.g2o", "VERTEX_SE2 0 1e308 0 0\n"))),
            "a.g2o:1: VERTEX_SE2 field 3 (estimate) is '1e308'; expected |x| <= 1e9 (the bound "
            "on coordinates, angles and measurements)");
  EXPECT_EQ(ErrorOf(ReadG2o(Write("b.g2o", poses + "EDGE_SE2 0 1 1 0 -2e9 1 0 0 1 0 1\n"))),
            "b.g2o:3: EDGE_SE2 field 6 (measurement) is '-2e9'; expected |x| <= 1e9 (the bound "
            "on coordinates, angles and measurements)");
  EXPECT_EQ(ErrorOf(ReadG2o(Write("c.g2o", poses + "EDGE_SE2 0 1 1 0 0 1e308 0 0 1e308 0 1e308\n"))),
            "c.g2o:3: EDGE_SE2 field 7 (information) is '1e308'; expected |x| <= 1e15 (the "
            "bound on information entries)");
  // At the bounds: accepted.
  const auto edge = ReadG2o(Write("d.g2o", poses + "EDGE_SE2 0 1 1e9 0 0 1e15 0 0 1e15 0 1e15\n"));
  ASSERT_TRUE(edge.ok()) << edge.status().ToString();
  EXPECT_EQ(edge->relative_poses[0].z.x(), 1e9);
}

TEST_F(InputLimitsTest, G2o3dBounds) {
  const std::string text =
      "VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_SE3:QUAT 1 1e12 0 0 0 0 0 1\n";
  EXPECT_THAT(ErrorOf(ReadG2o3d(Write("a3.g2o", text))),
              HasSubstr("a3.g2o:2: VERTEX_SE3:QUAT field 3 (estimate) is '1e12'; expected |x| <= 1e9"));
}

TEST_F(InputLimitsTest, IsamMeasurementAndSquareRootInformationBounds) {
  EXPECT_EQ(ErrorOf(ReadIsam(Write("a.isam", "ODOMETRY 0 1 1e308 0 0 1 0 0 1 0 1\n"))),
            "a.isam:1: ODOMETRY field 4 (measurement) is '1e308'; expected |x| <= 1e9 (the bound "
            "on coordinates, angles and measurements)");
  EXPECT_EQ(ErrorOf(ReadIsam(Write("b.isam", "ODOMETRY 0 1 1 0 0 1e8 0 0 1 0 1\n"))),
            "b.isam:1: ODOMETRY field 7 (sqrt information) is '1e8'; expected |x| <= 3.16e7 (the "
            "bound on square-root information entries)");
}

TEST_F(InputLimitsTest, Isam3dBounds) {
  std::string line = "EDGE3 0 1 1e308 0 0 0 0 0";
  for (int k = 0; k < 21; ++k) line += k == 0 || k == 6 || k == 11 || k == 15 || k == 18 || k == 20 ? " 1" : " 0";
  EXPECT_THAT(ErrorOf(ReadIsam3d(Write("a3.isam", line + "\n"))),
              HasSubstr("a3.isam:1: EDGE3 field 4 (measurement) is '1e308'; expected |x| <= 1e9"));
}

TEST_F(InputLimitsTest, MrclamTimeBoundInsteadOfASilentDrop) {
  const std::string folder = (dir_ / "mrclam").string();
  fs::create_directories(folder);
  std::ofstream(folder + "/Barcodes.dat") << "1 5\n2 14\n6 72\n";
  std::ofstream(folder + "/Robot1_Odometry.dat") << "100.0 0.1 0.0\n100.02 0.1 0.0\n";
  std::ofstream(folder + "/Robot1_Measurement.dat") << "100.01 72 1.5 0.1\n1e308 72 1.5 0.1\n";
  EXPECT_EQ(ErrorOf(ReadMrclam(folder, MrclamOptions())),
            "Robot1_Measurement.dat:2: measurement field 1 (time) is '1e308'; expected |x| <= "
            "1e12 (the bound on time stamps in seconds)");
  std::ofstream(folder + "/Robot1_Measurement.dat") << "100.01 72 1e10 0.1\n";
  EXPECT_EQ(ErrorOf(ReadMrclam(folder, MrclamOptions())),
            "Robot1_Measurement.dat:1: measurement field 3 (range) is '1e10'; expected |x| <= 1e9 "
            "(the bound on coordinates, angles and measurements)");
}

TEST_F(InputLimitsTest, NativeLogBounds) {
  const std::string head = "GRAPHSLAM_LOG 1\nPOSE 0 0.0 0 0 0\nPOSE 1 1.0 1 0 0\n";
  EXPECT_EQ(ErrorOf(ReadNativeLog(Write("a.log", head + "POSE 2 1e308 2 0 0\n"))),
            "a.log:4: POSE field 3 (time) is '1e308'; expected |x| <= 1e12 (the bound on time "
            "stamps in seconds)");
  EXPECT_EQ(ErrorOf(ReadNativeLog(Write("b.log", head + "ODOM 0 1 1 0 0 1e300 0 0 1 0 1\n"))),
            "b.log:4: ODOM field 7 (information) is '1e300'; expected |x| <= 1e15 (the bound on "
            "information entries)");
}

TEST_F(InputLimitsTest, LongLineInAZstdStreamIsAnErrorWithoutBufferingIt) {
  // 64 MiB of one comment line, compressed to a few KB.
  const std::string path = WriteZstd("long.g2o", "VERTEX_SE2 0 0 0 0\n#",
                                     std::string(size_t{1} << 20, 'x'), 64);
  EXPECT_LT(fs::file_size(path), 100000u);
  EXPECT_EQ(ErrorOf(ReadG2o(path)),
            "long.g2o:2: line is longer than 1048576 bytes; expected text records (a line of a "
            "supported format is < 1 KiB)");
  // The native log's parallel reader (storage/internal/text_blocks.h).
  const std::string native = WriteZstd("long.log", "GRAPHSLAM_LOG 1\n#",
                                       std::string(size_t{1} << 20, 'x'), 8);
  EXPECT_EQ(ErrorOf(ReadNativeLog(native)),
            "long.log:2: line is longer than 1048576 bytes; expected text records (a line of a "
            "supported format is < 1 KiB)");
}

TEST_F(InputLimitsTest, ZstdBombIsStoppedByTheExpansionBound) {
  // 128 MiB of newlines (short lines: the line limit does not stop this).
  const std::string path = WriteZstd("bomb.g2o", "", std::string(size_t{1} << 20, '\n'), 128);
  const auto compressed = static_cast<int64_t>(fs::file_size(path));
  ASSERT_LT(compressed * 1024 + (int64_t{64} << 20), int64_t{128} << 20);
  StatusOr<std::unique_ptr<InputFile>> input = InputFile::Open(path);
  ASSERT_TRUE(input.ok());
  Status status;
  std::string buffer(size_t{1} << 20, '\0');
  int64_t total = 0;
  while (status.ok()) {
    const size_t got = (*input)->Read(buffer.data(), buffer.size(), &status);
    total += static_cast<int64_t>(got);
    if (got < buffer.size()) break;
  }
  ASSERT_TRUE(status.IsCorruption()) << status.ToString();
  EXPECT_THAT(status.message(), HasSubstr("bomb.g2o: "));
  EXPECT_THAT(status.message(), HasSubstr("expected at most 1024 times the compressed size"));
  EXPECT_LT(total, int64_t{128} << 20);
  // Through a reader: the same error.
  EXPECT_THAT(ErrorOf(ReadG2o(path)), HasSubstr("decompression bomb"));
}

}  // namespace
}  // namespace graphslam::storage
