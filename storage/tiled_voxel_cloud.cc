#include "storage/tiled_voxel_cloud.h"

#include <malloc.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <system_error>
#include <utility>

#include "storage/atomic_file.h"
#include "storage/chunk_format.h"
#include "storage/env.h"
#include "storage/pcd_io.h"

namespace graphslam::map {
namespace {

namespace fs = std::filesystem;
namespace format = storage::chunk_format;

constexpr int64_t kVoxelOffset = int64_t{1} << 20;  // 21 bits an axis, as VoxelCloud
constexpr uint64_t kAxisMask = (uint64_t{1} << 21) - 1;
constexpr size_t kRecordBytes = 8 + 4 * 8 + 8 + 4;
constexpr size_t kSegmentFloats = size_t{1} << 18;  // 1 MiB of one column per LZF segment

// Closes a FILE* on scope exit.
struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f != nullptr) std::fclose(f);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// The PCD's columns (x, y, z [intensity] [run]), each compressed segment by
// segment (LZF, kSegmentFloats values) into DIR/column_<f>.lzf, then copied
// one after the other behind the header: binary_compressed's layout.
class CompressedColumns {
 public:
  Status Open(const std::string& dir, size_t fields) {
    paths_.resize(fields);
    files_.resize(fields);
    buffers_.resize(fields);
    compressed_bytes_.assign(fields, 0);
    for (size_t f = 0; f < fields; ++f) {
      paths_[f] = (fs::path(dir) / ("column_" + std::to_string(f) + ".lzf")).string();
      files_[f].reset(std::fopen(paths_[f].c_str(), "wb"));
      if (files_[f] == nullptr) return Status::IOError(paths_[f] + ": cannot create");
      buffers_[f].reserve(kSegmentFloats);
    }
    return Status::Ok();
  }

  // One point: values[f] for every column f.
  Status Add(const float* values) {
    for (size_t f = 0; f < buffers_.size(); ++f) {
      buffers_[f].push_back(values[f]);
      if (buffers_[f].size() == kSegmentFloats) GS_RETURN_IF_ERROR(Flush(f));
    }
    return Status::Ok();
  }

  Status Close() {
    for (size_t f = 0; f < files_.size(); ++f) {
      GS_RETURN_IF_ERROR(Flush(f));
      if (std::fclose(files_[f].release()) != 0)
        return Status::IOError(paths_[f] + ": close failed");
    }
    return Status::Ok();
  }

  uint64_t compressed_bytes() const {
    uint64_t total = 0;
    for (const uint64_t c : compressed_bytes_) total += c;
    return total;
  }

  Status CopyTo(storage::WritableFile* out) const {
    std::string block(size_t{1} << 20, '\0');
    for (const std::string& path : paths_) {
      File in(std::fopen(path.c_str(), "rb"));
      if (in == nullptr) return Status::IOError(path + ": cannot open");
      size_t n = 0;
      while ((n = std::fread(block.data(), 1, block.size(), in.get())) > 0)
        GS_RETURN_IF_ERROR(out->Append(std::string_view(block.data(), n)));
      if (std::ferror(in.get())) return Status::IOError(path + ": read failed");
    }
    return Status::Ok();
  }

 private:
  Status Flush(size_t f) {
    if (buffers_[f].empty()) return Status::Ok();
    segment_.clear();
    GS_RETURN_IF_ERROR(AppendLzfSegment(reinterpret_cast<const char*>(buffers_[f].data()),
                                        buffers_[f].size() * sizeof(float), &segment_));
    if (std::fwrite(segment_.data(), 1, segment_.size(), files_[f].get()) != segment_.size())
      return Status::IOError(paths_[f] + ": write failed: " + std::strerror(errno));
    compressed_bytes_[f] += segment_.size();
    buffers_[f].clear();
    return Status::Ok();
  }

  std::vector<std::string> paths_;
  std::vector<File> files_;
  std::vector<std::vector<float>> buffers_;
  std::vector<uint64_t> compressed_bytes_;
  std::string segment_;
};

// The binary_compressed PCD at `path`: header, the sizes, the columns.
Status WriteCompressedPcd(const std::string& path, const std::vector<std::string>& names,
                          uint64_t points, const CompressedColumns& columns) {
  const uint64_t uncompressed = points * names.size() * sizeof(float);
  const uint64_t compressed = columns.compressed_bytes();
  if (uncompressed > std::numeric_limits<uint32_t>::max() ||
      compressed > std::numeric_limits<uint32_t>::max())
    return Status::InvalidArgument(path + ": " + std::to_string(points) +
                                   " points exceed binary_compressed's 4 GiB (u32 sizes); "
                                   "expected a coarser --pcd-voxel");
  if (points > std::numeric_limits<uint32_t>::max())
    return Status::InvalidArgument(path + ": too many points for a PCD width");
  StatusOr<std::string> header = BinaryCompressedPcdHeader(names, static_cast<uint32_t>(points));
  GS_RETURN_IF_ERROR(header.status());
  std::string head = std::move(header).value();
  format::PutFixed32(&head, static_cast<uint32_t>(compressed));
  format::PutFixed32(&head, static_cast<uint32_t>(uncompressed));
  return storage::WriteFileAtomically(
      storage::Env::Default(), path, [&](storage::WritableFile* out) -> Status {
        GS_RETURN_IF_ERROR(out->Append(head));
        return columns.CopyTo(out);
      });
}

}  // namespace

TiledVoxelCloud::TiledVoxelCloud(TiledVoxelCloudOptions options) : options_(std::move(options)) {
  GS_CHECK(options_.voxel > 0.0 && options_.tile_bits >= 0 && options_.tile_bits <= 21);
  GS_CHECK(!options_.spill_dir.empty());
}

TiledVoxelCloud::~TiledVoxelCloud() {
  std::error_code error;
  fs::remove_all(options_.spill_dir, error);  // scratch only
}

std::string TiledVoxelCloud::TilePath(uint64_t id) const {
  char name[40];
  std::snprintf(name, sizeof(name), "tile_%016llx.vox", static_cast<unsigned long long>(id));
  return (fs::path(options_.spill_dir) / name).string();
}

Status TiledVoxelCloud::Add(const std::vector<Eigen::Vector3f>& world_points, const Scan& scan) {
  if (scan.has_intensity()) has_intensity_ = true;
  if (scan.run >= 0) has_run_ = true;
  ++clock_;
  const int bits = options_.tile_bits;
  uint64_t current_id = std::numeric_limits<uint64_t>::max();
  Tile* current = nullptr;
  for (size_t i = 0; i < world_points.size(); ++i) {
    const Eigen::Vector3f& p = world_points[i];
    uint64_t v[3];
    for (int a = 0; a < 3; ++a) {
      const int64_t cell = static_cast<int64_t>(std::floor(p[a] / options_.voxel)) + kVoxelOffset;
      v[a] = static_cast<uint64_t>(std::clamp<int64_t>(cell, 0, static_cast<int64_t>(kAxisMask)));
    }
    const uint64_t key = (v[0] << 42) | (v[1] << 21) | v[2];
    const uint64_t id = ((v[0] >> bits) << 42) | ((v[1] >> bits) << 21) | (v[2] >> bits);
    if (id != current_id) {
      current_id = id;
      auto [it, created] = tiles_.try_emplace(id);
      current = &it->second;
      if (created) ++stats_.tiles;
      GS_RETURN_IF_ERROR(Touch(id, current));
    }
    auto [it, inserted] = current->voxels.try_emplace(key);
    Accumulator& acc = it->second;
    if (inserted) ++resident_voxels_;
    if (acc.count == 0) acc.run = scan.run;
    acc.x += p.x();
    acc.y += p.y();
    acc.z += p.z();
    if (scan.has_intensity()) acc.intensity += scan.intensity[i];
    ++acc.count;
  }
  return EnforceBudget();
}

Status TiledVoxelCloud::Touch(uint64_t id, Tile* tile) {
  tile->last_touch = clock_;
  if (!tile->resident) GS_RETURN_IF_ERROR(Reload(id, tile));
  return Status::Ok();
}

Status TiledVoxelCloud::EnforceBudget() {
  const int64_t resident = resident_voxels_ * kBytesPerVoxel;
  stats_.peak_resident_bytes = std::max(stats_.peak_resident_bytes, resident);
  if (resident <= options_.budget_bytes) return Status::Ok();
  std::vector<std::pair<uint64_t, uint64_t>> order;  // (last touch, id), oldest first
  for (const auto& [id, tile] : tiles_)
    if (tile.resident && !tile.voxels.empty()) order.emplace_back(tile.last_touch, id);
  std::sort(order.begin(), order.end());
  for (const auto& [touch, id] : order) {
    if (resident_voxels_ * kBytesPerVoxel <= options_.budget_bytes / 2) break;
    GS_RETURN_IF_ERROR(Spill(id, &tiles_.at(id)));
  }
  malloc_trim(0);  // hand the freed nodes back, so RSS follows the budget
  return Status::Ok();
}

Status TiledVoxelCloud::Spill(uint64_t id, Tile* tile) {
  std::error_code error;
  fs::create_directories(options_.spill_dir, error);
  if (error) return Status::IOError(options_.spill_dir + ": mkdir: " + error.message());
  std::string bytes;
  bytes.reserve(8 + tile->voxels.size() * kRecordBytes);
  format::PutFixed64(&bytes, tile->voxels.size());
  for (const auto& [key, acc] : tile->voxels) {
    format::PutFixed64(&bytes, key);
    for (const double v : {acc.x, acc.y, acc.z, acc.intensity}) format::PutDouble(&bytes, v);
    format::PutFixed64(&bytes, static_cast<uint64_t>(acc.count));
    format::PutFixed32(&bytes, static_cast<uint32_t>(acc.run));
  }
  const std::string path = TilePath(id);
  File file(std::fopen(path.c_str(), "wb"));
  if (file == nullptr || std::fwrite(bytes.data(), 1, bytes.size(), file.get()) != bytes.size() ||
      std::fclose(file.release()) != 0)
    return Status::IOError(path + ": write of a spilled voxel tile failed: " + std::strerror(errno));
  resident_voxels_ -= static_cast<int64_t>(tile->voxels.size());
  std::unordered_map<uint64_t, Accumulator>().swap(tile->voxels);  // free the buckets too
  tile->resident = false;
  ++stats_.spills;
  return Status::Ok();
}

Status TiledVoxelCloud::Reload(uint64_t id, Tile* tile) {
  const std::string path = TilePath(id);
  std::error_code error;
  const auto size = fs::file_size(path, error);
  if (error) return Status::IOError(path + ": " + error.message());
  std::string bytes(static_cast<size_t>(size), '\0');
  {
    File file(std::fopen(path.c_str(), "rb"));
    if (file == nullptr || std::fread(bytes.data(), 1, bytes.size(), file.get()) != bytes.size())
      return Status::IOError(path + ": read of a spilled voxel tile failed");
  }
  const uint64_t count = bytes.size() >= 8 ? format::DecodeFixed64(bytes.data()) : 0;
  if (bytes.size() < 8 || bytes.size() != 8 + count * kRecordBytes)
    return Status::Corruption(path + ": " + std::to_string(bytes.size()) + " bytes; expected 8 + " +
                              std::to_string(count) + " x " + std::to_string(kRecordBytes));
  tile->voxels.reserve(static_cast<size_t>(count));
  const char* p = bytes.data() + 8;
  for (uint64_t r = 0; r < count; ++r, p += kRecordBytes) {
    Accumulator acc;
    acc.x = format::DecodeDouble(p + 8);
    acc.y = format::DecodeDouble(p + 16);
    acc.z = format::DecodeDouble(p + 24);
    acc.intensity = format::DecodeDouble(p + 32);
    acc.count = static_cast<int64_t>(format::DecodeFixed64(p + 40));
    acc.run = static_cast<int32_t>(format::DecodeFixed32(p + 48));
    tile->voxels.emplace(format::DecodeFixed64(p), acc);
  }
  fs::remove(path, error);
  resident_voxels_ += static_cast<int64_t>(count);
  tile->resident = true;
  ++stats_.reloads;
  return Status::Ok();
}

Status TiledVoxelCloud::Finish(const std::string& path) {
  std::vector<std::string> names = {"x", "y", "z"};
  if (has_intensity_) names.push_back("intensity");
  if (has_run_) names.push_back("run");
  std::error_code error;
  fs::create_directories(options_.spill_dir, error);
  if (error) return Status::IOError(options_.spill_dir + ": mkdir: " + error.message());
  CompressedColumns columns;
  GS_RETURN_IF_ERROR(columns.Open(options_.spill_dir, names.size()));
  // Tile after tile in id order, each tile's voxels in key order: the
  // voxel mean of every field.
  uint64_t points = 0;
  std::vector<std::pair<uint64_t, const Accumulator*>> sorted;
  while (!tiles_.empty()) {
    auto it = tiles_.begin();
    Tile& tile = it->second;
    if (!tile.resident) GS_RETURN_IF_ERROR(Reload(it->first, &tile));
    sorted.clear();
    sorted.reserve(tile.voxels.size());
    for (const auto& [key, acc] : tile.voxels) sorted.emplace_back(key, &acc);
    std::sort(sorted.begin(), sorted.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
    for (const auto& [key, acc] : sorted) {
      const double n = static_cast<double>(acc->count);
      float values[5] = {static_cast<float>(acc->x / n), static_cast<float>(acc->y / n),
                         static_cast<float>(acc->z / n), 0.0f, 0.0f};
      size_t k = 3;
      if (has_intensity_) values[k++] = static_cast<float>(acc->intensity / n);
      if (has_run_) values[k++] = static_cast<float>(acc->run);
      GS_RETURN_IF_ERROR(columns.Add(values));
      ++points;
    }
    resident_voxels_ -= static_cast<int64_t>(tile.voxels.size());
    tiles_.erase(it);
  }
  GS_RETURN_IF_ERROR(columns.Close());
  stats_.voxels = static_cast<int64_t>(points);
  GS_RETURN_IF_ERROR(WriteCompressedPcd(path, names, points, columns));
  fs::remove_all(options_.spill_dir, error);
  return Status::Ok();
}

}  // namespace graphslam::map
