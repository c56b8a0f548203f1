// tools/report_screenshots.sh, the script behind docs/results/report-*.png,
// with Debian's headless Chromium: a small job with scans and GPS writes its
// report.html, the script screenshots it, and the two PNGs are 1024 and
// 1600 px wide, taller than a screen (the whole page) and not blank (most of
// the page is background, but text, tables and figures cover a good part of
// it in many colours).
//
// Without chromium the test is skipped, except under CI=true, where
// tools/setup/install_dependencies.sh has installed it: there a missing
// chromium is a failure.
#include <png.h>
#include <unistd.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "tests/testing/subprocess.h"
#include "tools/exit_codes.h"

namespace graphslam::tools {
namespace {

namespace fs = std::filesystem;

bool ChromiumInstalled() {
  const char* path = std::getenv("PATH");
  std::string dirs = path != nullptr ? path : "/usr/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const fs::path candidate = fs::path(dirs.substr(start, end - start)) / "chromium";
    if (access(candidate.c_str(), X_OK) == 0) return true;
    start = end + 1;
  }
  return false;
}

struct Image {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgb;
};

// libpng's simplified API; an empty image if the file is not a PNG.
Image ReadPng(const std::string& path) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  Image out;
  if (!png_image_begin_read_from_file(&image, path.c_str())) return out;
  image.format = PNG_FORMAT_RGB;
  std::vector<uint8_t> rgb(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, rgb.data(), 0, nullptr)) {
    png_image_free(&image);
    return out;
  }
  out.width = image.width;
  out.height = image.height;
  out.rgb = std::move(rgb);
  return out;
}

TEST(ReportScreenshots, BothWidthsWholePageNotBlank) {
  if (!ChromiumInstalled()) {
    const char* ci = std::getenv("CI");
    if (ci != nullptr && std::string(ci) == "true")
      FAIL() << "chromium missing under CI=true (tools/setup/install_dependencies.sh installs it)";
    GTEST_SKIP() << "chromium is not installed";
  }
  const fs::path dir = fs::temp_directory_path() / ("graphslam_shots_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "job.yaml")
      << "output: out\nthreads: 2\ncompare_without_gps: true\nmap: {resolution: 0.2, max_range: 25}\n"
         "runs:\n  - name: campus\n    format: simulate\n"
         "    simulate: {poses: 300, runs: 3, seed: 4, sensor_range: 8, gps_every: 5,\n"
         "               gps_denied_region: [-10, -10, 90, 90], scans: true, scan_beams: 60,\n"
         "               scan_max_range: 25}\n";
  const testing::GraphslamRun job = testing::RunGraphslamCaptured(
      {"run", (dir / "job.yaml").string(), "-q"}, (dir / "capture").string());
  ASSERT_EQ(job.exit_code, kExitOk) << job.err;
  ASSERT_TRUE(fs::exists(dir / "out" / "report.html"));

  const std::string command = "bash '" + std::string(GRAPHSLAM_SOURCE_DIR) +
                              "/tools/report_screenshots.sh' '" + (dir / "out/report.html").string() +
                              "' '" + (dir / "shots").string() + "' > '" +
                              (dir / "script.log").string() + "' 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  for (const uint32_t width : {1024u, 1600u}) {
    SCOPED_TRACE(width);
    const Image png = ReadPng((dir / "shots" / ("report-" + std::to_string(width) + ".png")).string());
    ASSERT_EQ(png.width, width);
    EXPECT_GT(png.height, 2000u);  // the whole page, not one window of it
    // Not blank: pixels unlike the background (the top-left one) and colours.
    const uint8_t* bg = png.rgb.data();
    size_t foreground = 0;
    std::set<uint32_t> colours;
    for (size_t p = 0; p + 2 < png.rgb.size(); p += 3) {
      const uint8_t* px = png.rgb.data() + p;
      if (px[0] != bg[0] || px[1] != bg[1] || px[2] != bg[2]) ++foreground;
      if (colours.size() < 1000) colours.insert((px[0] << 16) | (px[1] << 8) | px[2]);
    }
    const double pixels = static_cast<double>(png.width) * png.height;
    EXPECT_GT(foreground / pixels, 0.05);
    EXPECT_GE(colours.size(), 100u);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace graphslam::tools
