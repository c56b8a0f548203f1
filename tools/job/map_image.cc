#include "tools/job/map_image.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>

#include "storage/pcd_io.h"
#include "tools/job/svg_figure.h"

namespace graphslam::tools::job {
namespace {

void PutUint32(uint32_t v, std::string* out) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<char>((v >> shift) & 0xff));
}

void Chunk(const char type[4], const std::string& data, std::string* out) {
  PutUint32(static_cast<uint32_t>(data.size()), out);
  const std::string body = std::string(type, 4) + data;
  out->append(body);
  PutUint32(static_cast<uint32_t>(
                crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))),
            out);
}

std::array<int, 3> Rgb(const std::string& hex) {
  return {std::stoi(hex.substr(1, 2), nullptr, 16), std::stoi(hex.substr(3, 2), nullptr, 16),
          std::stoi(hex.substr(5, 2), nullptr, 16)};
}

}  // namespace

std::string EncodePng(int width, int height, const std::vector<uint8_t>& rgb) {
  std::string raw;
  raw.reserve(static_cast<size_t>(height) * (static_cast<size_t>(width) * 3 + 1));
  for (int row = 0; row < height; ++row) {
    raw.push_back(0);  // filter: none
    raw.append(reinterpret_cast<const char*>(rgb.data()) + static_cast<size_t>(row) * width * 3,
               static_cast<size_t>(width) * 3);
  }
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::string deflated(size, '\0');
  compress2(reinterpret_cast<Bytef*>(deflated.data()), &size,
            reinterpret_cast<const Bytef*>(raw.data()), static_cast<uLong>(raw.size()), 6);
  deflated.resize(size);
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string header;
  PutUint32(static_cast<uint32_t>(width), &header);
  PutUint32(static_cast<uint32_t>(height), &header);
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bit, RGB, deflate, filter 0, no interlace
  Chunk("IHDR", header, &png);
  Chunk("IDAT", deflated, &png);
  Chunk("IEND", "", &png);
  return png;
}

StatusOr<MapRaster> RenderMapRaster(const std::vector<std::string>& pcd_paths, int max_pixels,
                                    double min_pixel) {
  std::vector<map::PcdContents> clouds;
  MapRaster raster;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  for (const std::string& path : pcd_paths) {
    StatusOr<map::PcdContents> cloud = map::ReadPcd(path);
    if (!cloud.ok()) return cloud.status();
    for (const Eigen::Vector3f& p : cloud->points) {
      x0 = std::min(x0, static_cast<double>(p.x())), x1 = std::max(x1, static_cast<double>(p.x()));
      y0 = std::min(y0, static_cast<double>(p.y())), y1 = std::max(y1, static_cast<double>(p.y()));
    }
    raster.points += static_cast<int64_t>(cloud->points.size());
    clouds.push_back(std::move(cloud).value());
  }
  if (raster.points == 0) return raster;
  const double pixel = std::max(std::max({x1 - x0, y1 - y0, 1e-3}) / max_pixels, min_pixel);
  const int width = std::max(1, static_cast<int>(std::ceil((x1 - x0) / pixel)) + 1);
  const int height = std::max(1, static_cast<int>(std::ceil((y1 - y0) / pixel)) + 1);
  raster.x0 = x0, raster.y0 = y0;
  raster.x1 = x0 + width * pixel, raster.y1 = y0 + height * pixel;
  // Per pixel: point count per run (runs are few; a small map per pixel).
  std::vector<std::map<int, int32_t>> counts(static_cast<size_t>(width) * height);
  std::set<int> runs;
  for (const map::PcdContents& cloud : clouds) {
    for (size_t i = 0; i < cloud.points.size(); ++i) {
      const int col = static_cast<int>((cloud.points[i].x() - x0) / pixel);
      const int row = height - 1 - static_cast<int>((cloud.points[i].y() - y0) / pixel);
      const int run = cloud.run.empty() ? 0 : static_cast<int>(std::lround(cloud.run[i]));
      runs.insert(run);
      ++counts[static_cast<size_t>(row) * width + col][run];
    }
  }
  raster.runs.assign(runs.begin(), runs.end());
  int32_t most = 1;
  for (const auto& pixel_counts : counts) {
    int32_t n = 0;
    for (const auto& [run, c] : pixel_counts) n += c;
    most = std::max(most, n);
  }
  std::vector<uint8_t> rgb(static_cast<size_t>(width) * height * 3, 255);
  for (size_t p = 0; p < counts.size(); ++p) {
    if (counts[p].empty()) continue;
    int32_t n = 0, best = 0;
    int run = 0;
    for (const auto& [r, c] : counts[p]) {
      n += c;
      if (c > best) best = c, run = r;
    }
    const double t = 0.3 + 0.7 * std::log1p(n) / std::log1p(most);
    const std::array<int, 3> colour = Rgb(SeriesColour(static_cast<size_t>(std::max(run, 0))));
    for (int k = 0; k < 3; ++k)
      rgb[p * 3 + k] = static_cast<uint8_t>(std::lround(255 + (colour[k] - 255) * t));
  }
  raster.png = EncodePng(width, height, rgb);
  return raster;
}

}  // namespace graphslam::tools::job
