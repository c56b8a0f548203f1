#include "storage/pcd_io.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>

#include "storage/atomic_file.h"
#include "storage/env.h"
#include "storage/internal/pcl_module_loader.h"

namespace graphslam::map {
namespace {

constexpr int64_t kVoxelOffset = int64_t{1} << 20;  // 21 bits an axis: +-1e6 voxels
constexpr uint64_t kVoxelMask = (uint64_t{1} << 21) - 1;

}  // namespace

void VoxelCloud::Add(const std::vector<Eigen::Vector3f>& world_points, const Scan& scan) {
  if (scan.has_intensity()) has_intensity_ = true;
  if (scan.run >= 0) has_run_ = true;
  for (size_t i = 0; i < world_points.size(); ++i) {
    const Eigen::Vector3f& p = world_points[i];
    uint64_t key = 0;
    for (int a = 0; a < 3; ++a) {
      const int64_t v = static_cast<int64_t>(std::floor(p[a] / voxel_)) + kVoxelOffset;
      key = (key << 21) | (static_cast<uint64_t>(std::clamp<int64_t>(v, 0, kVoxelMask)));
    }
    Accumulator& acc = voxels_[key];
    if (acc.count == 0) acc.run = scan.run;
    acc.x += p.x();
    acc.y += p.y();
    acc.z += p.z();
    if (scan.has_intensity()) acc.intensity += scan.intensity[i];
    ++acc.count;
  }
}

std::vector<VoxelCloud::Point> VoxelCloud::Points() const {
  std::vector<std::pair<uint64_t, const Accumulator*>> sorted;
  sorted.reserve(voxels_.size());
  for (const auto& [key, acc] : voxels_) sorted.emplace_back(key, &acc);
  std::sort(sorted.begin(), sorted.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  std::vector<Point> out;
  out.reserve(sorted.size());
  for (const auto& [key, acc] : sorted) {
    const double n = static_cast<double>(acc->count);
    out.push_back({Eigen::Vector3f(static_cast<float>(acc->x / n), static_cast<float>(acc->y / n),
                                   static_cast<float>(acc->z / n)),
                   static_cast<float>(acc->intensity / n), static_cast<float>(acc->run)});
  }
  return out;
}

Status WritePcd(const std::string& path, const VoxelCloud& cloud) {
  StatusOr<const internal::PclModuleApi*> pcl = internal::LoadPclModule();
  GS_RETURN_IF_ERROR(pcl.status());
  const std::vector<VoxelCloud::Point> points = cloud.Points();
  std::vector<std::string> names = {"x", "y", "z"};
  if (cloud.has_intensity()) names.push_back("intensity");
  if (cloud.has_run()) names.push_back("run");
  std::vector<float> values;
  values.reserve(points.size() * names.size());
  for (const VoxelCloud::Point& p : points) {
    values.insert(values.end(), {p.xyz.x(), p.xyz.y(), p.xyz.z()});
    if (cloud.has_intensity()) values.push_back(p.intensity);
    if (cloud.has_run()) values.push_back(p.run);
  }
  std::string encoded;
  if (const std::string error = (*pcl)->encode_binary_compressed(
          names, values, static_cast<uint32_t>(points.size()), &encoded);
      !error.empty())
    return Status::IOError("writing " + path + ": " + error);
  return storage::WriteStringAtomically(storage::Env::Default(), path, encoded);
}

StatusOr<std::string> BinaryCompressedPcdHeader(const std::vector<std::string>& names,
                                                uint32_t points) {
  StatusOr<const internal::PclModuleApi*> pcl = internal::LoadPclModule();
  GS_RETURN_IF_ERROR(pcl.status());
  std::string header;
  if (const std::string error = (*pcl)->binary_compressed_header(names, points, &header);
      !error.empty())
    return Status::IOError("PCD header: " + error);
  // PCL 1.13's string variant stops before the DATA line (its stream variant
  // and writeBinaryCompressed add it).
  return header + "DATA binary_compressed\n";
}

Status AppendLzfSegment(const char* data, size_t n, std::string* out) {
  if (n == 0) return Status::Ok();
  if (n > (size_t{1} << 30)) return Status::InvalidArgument("LZF segment above 1 GiB");
  StatusOr<const internal::PclModuleApi*> pcl = internal::LoadPclModule();
  GS_RETURN_IF_ERROR(pcl.status());
  // LZF expands incompressible input by at most 1 byte in 32 (a literal-run header).
  const size_t capacity = n + n / 16 + 64;
  const size_t start = out->size();
  out->resize(start + capacity);
  const unsigned int written =
      (*pcl)->lzf_compress(data, static_cast<unsigned int>(n), out->data() + start,
                           static_cast<unsigned int>(capacity));
  if (written == 0) {
    out->resize(start);
    return Status::IOError("PCL's lzfCompress failed on " + std::to_string(n) + " bytes");
  }
  out->resize(start + written);
  return Status::Ok();
}

namespace {

// PCL 1.13's PCDReader crashes on some files that are not PCD at all (a text
// file without FIELDS): the header is checked first. Required: FIELDS, SIZE,
// TYPE with as many entries each, WIDTH or POINTS, and DATA.
Status CheckPcdHeader(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::NotFound(path + ": cannot open");
  size_t fields = 0, sizes = 0, types = 0;
  bool count = false;
  std::string line;
  for (int lines = 0; lines < 64 && std::getline(in, line); ++lines) {
    std::istringstream tokens(line);
    std::string key;
    if (!(tokens >> key) || key[0] == '#') continue;
    size_t n = 0;
    for (std::string value; tokens >> value;) ++n;
    if (key == "FIELDS") fields = n;
    else if (key == "SIZE") sizes = n;
    else if (key == "TYPE") types = n;
    else if (key == "WIDTH" || key == "POINTS") count = true;
    else if (key == "DATA") {
      if (fields == 0 || sizes != fields || types != fields || !count)
        return Status::Corruption(path + ": PCD header has " + std::to_string(fields) +
                                  " FIELDS, " + std::to_string(sizes) + " SIZE and " +
                                  std::to_string(types) +
                                  " TYPE entries; expected FIELDS, SIZE and TYPE of equal length "
                                  "and WIDTH or POINTS before DATA");
      return Status::Ok();
    } else if (key != "VERSION" && key != "COUNT" && key != "HEIGHT" && key != "VIEWPOINT") {
      return Status::Corruption(path + ": '" + key +
                                "' is not a PCD header key; expected VERSION, FIELDS, SIZE, TYPE, "
                                "COUNT, WIDTH, HEIGHT, VIEWPOINT, POINTS or DATA");
    }
  }
  return Status::Corruption(path + ": no DATA line in the PCD header");
}

}  // namespace

StatusOr<PcdContents> ReadPcd(const std::string& path) {
  GS_RETURN_IF_ERROR(CheckPcdHeader(path));
  StatusOr<const internal::PclModuleApi*> pcl = internal::LoadPclModule();
  GS_RETURN_IF_ERROR(pcl.status());
  internal::PcdBlob blob;
  if (const std::string error = (*pcl)->load(path, &blob); !error.empty())
    return Status::Corruption(path + ": " + error);
  PcdContents contents;
  {
    std::ifstream in(path, std::ios::binary);
    std::string line;
    while (std::getline(in, line)) {
      if (line.rfind("DATA ", 0) == 0) {
        contents.data_type = line.substr(5);
        break;
      }
    }
  }
  auto field_offset = [&](const std::string& name) -> int {
    for (const internal::PcdField& f : blob.fields) {
      if (f.name == name && f.float32) return static_cast<int>(f.offset);
    }
    return -1;
  };
  const int ox = field_offset("x"), oy = field_offset("y"), oz = field_offset("z");
  if (ox < 0 || oy < 0 || oz < 0) return Status::Corruption(path + ": no float x y z fields");
  const int oi = field_offset("intensity"), orun = field_offset("run");
  const size_t n = static_cast<size_t>(blob.width) * blob.height;
  auto at = [&](size_t i, int off) {
    float v;
    std::memcpy(&v, blob.data.data() + i * blob.point_step + static_cast<size_t>(off), sizeof(v));
    return v;
  };
  for (size_t i = 0; i < n; ++i) {
    contents.points.emplace_back(at(i, ox), at(i, oy), at(i, oz));
    if (oi >= 0) contents.intensity.push_back(at(i, oi));
    if (orun >= 0) contents.run.push_back(at(i, orun));
  }
  return contents;
}

}  // namespace graphslam::map
