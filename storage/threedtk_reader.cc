#include "storage/threedtk_reader.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

namespace graphslam::map {
namespace {

std::string ScanPath(const std::string& dir, int number, const char* ext) {
  char name[64];
  std::snprintf(name, sizeof(name), "scan%03d.%s", number, ext);
  return (std::filesystem::path(dir) / name).string();
}

// Parses up to `max` doubles separated by blanks; returns how many.
int ParseNumbers(const char* begin, const char* end, double* out, int max, bool* bad) {
  int n = 0;
  *bad = false;
  const char* p = begin;
  while (true) {
    while (p < end && (*p == ' ' || *p == '\t' || *p == '\r')) ++p;
    if (p >= end) break;
    if (n == max) {
      *bad = true;
      break;
    }
    const auto [next, ec] = std::from_chars(p, end, out[n]);
    if (ec != std::errc()) {
      *bad = true;
      break;
    }
    ++n;
    p = next;
  }
  return n;
}

}  // namespace

Eigen::Matrix3d ThreeDtkRotation(double rx, double ry, double rz) {
  return (Eigen::AngleAxisd(rx, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(ry, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(rz, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Eigen::Matrix3d ThreeDtkToRightHanded() {
  Eigen::Matrix3d c;
  c << 0, 0, 1, -1, 0, 0, 0, 1, 0;
  return c;
}

StatusOr<std::vector<int>> List3dtkScans(const std::string& dir) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) {
    return Status::NotFound(dir + ": not a directory");
  }
  std::vector<int> numbers;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    const std::string name = entry.path().filename().string();
    int number = 0;
    char tail[8] = {0};
    if (std::sscanf(name.c_str(), "scan%d.%7s", &number, tail) == 2 && std::string(tail) == "3d" &&
        std::filesystem::exists(ScanPath(dir, number, "pose"))) {
      numbers.push_back(number);
    }
  }
  if (ec) return Status::IOError(dir + ": " + ec.message());
  if (numbers.empty()) return Status::NotFound(dir + ": no 3DTK scanNNN.3d with scanNNN.pose");
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}

StatusOr<Scan> Read3dtkScan(const std::string& dir, int number, int64_t pose_index) {
  const Eigen::Matrix3d c = ThreeDtkToRightHanded();
  Scan scan;
  scan.pose = pose_index;
  {
    const std::string path = ScanPath(dir, number, "pose");
    std::ifstream in(path);
    if (!in) return Status::NotFound(path + ": cannot open");
    double v[6];
    for (int i = 0; i < 6; ++i) {
      if (!(in >> v[i]) || !std::isfinite(v[i])) {
        return Status::Corruption(path + ": expected 6 numbers (x y z [cm], rx ry rz [deg]), got " +
                                  std::to_string(i));
      }
    }
    constexpr double kDeg = 3.14159265358979323846 / 180.0;
    const Eigen::Matrix3d r = c * ThreeDtkRotation(v[3] * kDeg, v[4] * kDeg, v[5] * kDeg) * c.transpose();
    scan.sensor_pose.q = Eigen::Quaterniond(r).normalized();
    scan.sensor_pose.t = c * Eigen::Vector3d(v[0], v[1], v[2]) / 100.0;
  }
  const std::string path = ScanPath(dir, number, "3d");
  std::ifstream in(path);
  if (!in) return Status::NotFound(path + ": cannot open");
  std::string line;
  int64_t line_no = 0;
  int columns = -1;
  while (std::getline(in, line)) {
    ++line_no;
    double v[4];
    bool bad = false;
    const int n = ParseNumbers(line.data(), line.data() + line.size(), v, 4, &bad);
    if (n == 0 && !bad) continue;  // blank line
    if (bad || n < 3 || (columns >= 0 && n != columns)) {
      // 3DTK writes an optional "W x H" header on the first line.
      if (line_no == 1 && line.find('x') != std::string::npos) continue;
      return Status::Corruption(path + ":" + std::to_string(line_no) +
                                ": expected x y z [reflectance] (" +
                                (columns < 0 ? std::string("3 or 4") : std::to_string(columns)) +
                                " numbers), got '" + line + "'");
    }
    columns = n;
    const Eigen::Vector3d p = c * Eigen::Vector3d(v[0], v[1], v[2]) / 100.0;
    scan.points.push_back(p.cast<float>());
    if (n == 4) scan.intensity.push_back(static_cast<float>(v[3]));
  }
  if (in.bad()) return Status::IOError(path + ": read error");
  return scan;
}

}  // namespace graphslam::map
