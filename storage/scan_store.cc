#include "storage/scan_store.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <system_error>

#include "storage/threedtk_reader.h"
#include "storage/atomic_file.h"
#include "storage/crc32c.h"
#include "storage/env.h"

namespace graphslam::map {
namespace {

constexpr char kHeaderMagic[8] = {'G', 'S', 'S', 'C', 'A', 'N', '0', '1'};
constexpr char kFooterMagic[8] = {'G', 'S', 'S', 'C', 'E', 'N', 'D', '1'};
constexpr size_t kHeaderBytes = 8 + 4 + 4 + 8;  // magic, version, flags, num_scans
constexpr size_t kFooterBytes = 8 + 8;          // magic, num_scans
constexpr size_t kFixedPayload = 8 + 4 + 4 + 7 * 8 + 8;
constexpr uint32_t kFlagIntensity = 1;

template <typename T>
void Put(std::string* out, const T& v) {
  out->append(reinterpret_cast<const char*>(&v), sizeof(T));
}
template <typename T>
T Get(const char* p) {
  T v;
  std::memcpy(&v, p, sizeof(T));
  return v;
}

std::string ChunkName(int64_t index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06lld.gss", static_cast<long long>(index));
  return name;
}

std::string EncodeScan(const Scan& scan) {
  std::string payload;
  const uint64_t n = scan.points.size();
  payload.reserve(kFixedPayload + n * 16);
  Put<int64_t>(&payload, scan.pose);
  Put<int32_t>(&payload, scan.run);
  Put<uint32_t>(&payload, scan.has_intensity() ? kFlagIntensity : 0u);
  const core::Pose3& x = scan.sensor_pose;
  for (double v : {x.q.w(), x.q.x(), x.q.y(), x.q.z(), x.t.x(), x.t.y(), x.t.z()}) Put(&payload, v);
  Put<uint64_t>(&payload, n);
  payload.append(reinterpret_cast<const char*>(scan.points.data()), n * 3 * sizeof(float));
  if (scan.has_intensity()) {
    payload.append(reinterpret_cast<const char*>(scan.intensity.data()), n * sizeof(float));
  }
  return payload;
}

Status DecodeScan(const std::string& where, const char* p, size_t size, Scan* scan) {
  if (size < kFixedPayload) return Status::Corruption(where + ": record shorter than its fixed part");
  scan->pose = Get<int64_t>(p);
  scan->run = Get<int32_t>(p + 8);
  const uint32_t flags = Get<uint32_t>(p + 12);
  double v[7];
  for (int i = 0; i < 7; ++i) v[i] = Get<double>(p + 16 + 8 * i);
  scan->sensor_pose.q = Eigen::Quaterniond(v[0], v[1], v[2], v[3]);
  scan->sensor_pose.t = Eigen::Vector3d(v[4], v[5], v[6]);
  const uint64_t n = Get<uint64_t>(p + 72);
  const size_t per_point = (flags & kFlagIntensity) ? 16 : 12;
  if (flags > kFlagIntensity || n > (size - kFixedPayload) / per_point ||
      kFixedPayload + n * per_point != size) {
    return Status::Corruption(where + ": record of " + std::to_string(size) + " bytes, expected " +
                              std::to_string(kFixedPayload + n * per_point) + " for " +
                              std::to_string(n) + " points (flags " + std::to_string(flags) + ")");
  }
  if (std::abs(scan->sensor_pose.q.norm() - 1.0) > 1e-6) {
    return Status::Corruption(where + ": sensor pose quaternion not unit");
  }
  scan->points.resize(n);
  std::memcpy(static_cast<void*>(scan->points.data()), p + kFixedPayload, n * 12);
  scan->intensity.clear();
  if (flags & kFlagIntensity) {
    scan->intensity.resize(n);
    std::memcpy(scan->intensity.data(), p + kFixedPayload + n * 12, n * 4);
  }
  return Status::Ok();
}

}  // namespace

Status InMemoryScanSource::Load(int64_t index, std::vector<Scan>* scans) const {
  if (index < 0 || index >= NumChunks()) return Status::InvalidArgument("scan chunk out of range");
  const size_t begin = static_cast<size_t>(index) * per_chunk_;
  const size_t end = std::min(scans_.size(), begin + per_chunk_);
  scans->assign(scans_.begin() + static_cast<std::ptrdiff_t>(begin),
                scans_.begin() + static_cast<std::ptrdiff_t>(end));
  return Status::Ok();
}

StatusOr<std::unique_ptr<ScanStoreWriter>> ScanStoreWriter::Create(const std::string& dir,
                                                                    int64_t target_chunk_bytes) {
  std::unique_ptr<ScanStoreWriter> writer(new ScanStoreWriter());
  writer->dir_ = (std::filesystem::path(dir) / kScanStoreDirectory).string();
  writer->target_bytes_ = std::max<int64_t>(1, target_chunk_bytes);
  std::error_code ec;
  std::filesystem::create_directories(writer->dir_, ec);
  if (ec) return Status::IOError(writer->dir_ + ": " + ec.message());
  const std::string manifest = writer->dir_ + "/" + kScanStoreManifest;
  if (std::filesystem::exists(manifest)) {
    GS_RETURN_IF_ERROR(storage::Env::Default()->RemoveFile(manifest));
    GS_RETURN_IF_ERROR(storage::Env::Default()->SyncDirectory(writer->dir_));
  }
  return writer;
}

StatusOr<std::unique_ptr<ScanStoreWriter>> ScanStoreWriter::Resume(const std::string& dir,
                                                                    int64_t target_chunk_bytes,
                                                                    std::vector<Entry> done) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<ScanStoreWriter> writer, Create(dir, target_chunk_bytes));
  for (size_t k = 0; k < done.size(); ++k) {
    if (done[k].file != ChunkName(static_cast<int64_t>(k)))
      return Status::InvalidArgument("scan chunk " + std::to_string(k) + " recorded as '" +
                                     done[k].file + "'; expected " +
                                     ChunkName(static_cast<int64_t>(k)));
  }
  writer->entries_ = std::move(done);
  return writer;
}

Status ScanStoreWriter::Add(const Scan& scan) {
  if (!scan.intensity.empty() && scan.intensity.size() != scan.points.size()) {
    return Status::InvalidArgument("scan of pose " + std::to_string(scan.pose) + ": " +
                                   std::to_string(scan.intensity.size()) + " intensities for " +
                                   std::to_string(scan.points.size()) + " points");
  }
  const std::string payload = EncodeScan(scan);
  if (payload.size() > 0xFFFFFFFFu) return Status::InvalidArgument("scan larger than 4 GiB");
  Put<uint32_t>(&pending_, static_cast<uint32_t>(payload.size()));
  Put<uint32_t>(&pending_, storage::crc32c::Mask(storage::crc32c::Value(payload)));
  pending_ += payload;
  ++pending_scans_;
  pending_points_ += static_cast<int64_t>(scan.points.size());
  if (static_cast<int64_t>(pending_.size()) >= target_bytes_) return Flush();
  return Status::Ok();
}

Status ScanStoreWriter::Flush() {
  if (pending_scans_ == 0) return Status::Ok();
  std::string file;
  file.append(kHeaderMagic, 8);
  Put<uint32_t>(&file, kScanStoreVersion);
  Put<uint32_t>(&file, 0);
  Put<uint64_t>(&file, static_cast<uint64_t>(pending_scans_));
  file += pending_;
  file.append(kFooterMagic, 8);
  Put<uint64_t>(&file, static_cast<uint64_t>(pending_scans_));
  const std::string name = ChunkName(static_cast<int64_t>(entries_.size()));
  GS_RETURN_IF_ERROR(
      storage::WriteStringAtomically(storage::Env::Default(), dir_ + "/" + name, file));
  entries_.push_back({name, pending_scans_, pending_points_, static_cast<int64_t>(file.size())});
  pending_.clear();
  pending_scans_ = pending_points_ = 0;
  return Status::Ok();
}

Status ScanStoreWriter::Finish() {
  GS_RETURN_IF_ERROR(Flush());
  nlohmann::json manifest;
  manifest["format"] = kScanStoreFormat;
  manifest["version"] = kScanStoreVersion;
  int64_t scans = 0, points = 0;
  nlohmann::json chunks = nlohmann::json::array();
  for (const Entry& e : entries_) {
    chunks.push_back({{"file", e.file}, {"scans", e.scans}, {"points", e.points}, {"bytes", e.bytes}});
    scans += e.scans;
    points += e.points;
  }
  manifest["num_chunks"] = entries_.size();
  manifest["total_scans"] = scans;
  manifest["total_points"] = points;
  manifest["chunks"] = chunks;
  return storage::WriteStringAtomically(storage::Env::Default(),
                                        dir_ + "/" + kScanStoreManifest, manifest.dump(2) + "\n");
}

bool DiskScanStore::Exists(const std::string& dir) {
  std::error_code ec;
  return std::filesystem::exists(
      std::filesystem::path(dir) / kScanStoreDirectory / kScanStoreManifest, ec);
}

StatusOr<std::unique_ptr<DiskScanStore>> DiskScanStore::Open(const std::string& dir) {
  std::unique_ptr<DiskScanStore> store(new DiskScanStore());
  store->dir_ = (std::filesystem::path(dir) / kScanStoreDirectory).string();
  const std::string path = store->dir_ + "/" + kScanStoreManifest;
  std::ifstream in(path);
  if (!in) return Status::NotFound(path + ": no scan store manifest");
  nlohmann::json manifest;
  try {
    manifest = nlohmann::json::parse(in);
    if (manifest.at("format").get<std::string>() != kScanStoreFormat) {
      return Status::Corruption(path + ": format is not " + std::string(kScanStoreFormat));
    }
    const int version = manifest.at("version").get<int>();
    if (version > kScanStoreVersion) {
      return Status::NotSupported(path + ": version " + std::to_string(version) + ", newest known " +
                                  std::to_string(kScanStoreVersion));
    }
    int64_t k = 0;
    for (const nlohmann::json& chunk : manifest.at("chunks")) {
      const std::string file = chunk.at("file").get<std::string>();
      if (file != ChunkName(k)) {
        return Status::Corruption(path + ": chunk " + std::to_string(k) + " is '" + file +
                                  "', expected " + ChunkName(k));
      }
      store->files_.push_back(file);
      store->scans_.push_back(chunk.at("scans").get<int64_t>());
      store->total_points_ += chunk.at("points").get<int64_t>();
      store->total_scans_ += store->scans_.back();
      ++k;
    }
    if (store->total_scans_ != manifest.at("total_scans").get<int64_t>() ||
        store->total_points_ != manifest.at("total_points").get<int64_t>()) {
      return Status::Corruption(path + ": totals differ from the sums over chunks");
    }
  } catch (const nlohmann::json::exception& e) {
    return Status::Corruption(path + ": " + e.what());
  }
  return store;
}

Status DiskScanStore::Load(int64_t index, std::vector<Scan>* scans) const {
  if (index < 0 || index >= NumChunks()) return Status::InvalidArgument("scan chunk out of range");
  const std::string path = dir_ + "/" + files_[static_cast<size_t>(index)];
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::NotFound(path + ": cannot open");
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (data.size() < kHeaderBytes + kFooterBytes || std::memcmp(data.data(), kHeaderMagic, 8) != 0) {
    return Status::Corruption(path + ": not a scan chunk (bad magic or too short)");
  }
  const uint32_t version = Get<uint32_t>(data.data() + 8);
  if (version != static_cast<uint32_t>(kScanStoreVersion)) {
    return Status::NotSupported(path + ": scan chunk version " + std::to_string(version));
  }
  const uint64_t count = Get<uint64_t>(data.data() + 16);
  const size_t footer = data.size() - kFooterBytes;
  if (std::memcmp(data.data() + footer, kFooterMagic, 8) != 0 ||
      Get<uint64_t>(data.data() + footer + 8) != count ||
      count != static_cast<uint64_t>(scans_[static_cast<size_t>(index)])) {
    return Status::Corruption(path + ": truncated, or scan counts of header, footer and manifest differ");
  }
  scans->clear();
  size_t pos = kHeaderBytes;
  for (uint64_t i = 0; i < count; ++i) {
    const std::string where = path + ": scan record " + std::to_string(i);
    if (pos + 8 > footer) return Status::Corruption(where + ": truncated");
    const uint32_t length = Get<uint32_t>(data.data() + pos);
    const uint32_t crc = storage::crc32c::Unmask(Get<uint32_t>(data.data() + pos + 4));
    if (pos + 8 + length > footer) return Status::Corruption(where + ": truncated");
    const char* payload = data.data() + pos + 8;
    if (storage::crc32c::Value(payload, length) != crc) {
      return Status::Corruption(where + ": checksum mismatch");
    }
    Scan scan;
    GS_RETURN_IF_ERROR(DecodeScan(where, payload, length, &scan));
    scans->push_back(std::move(scan));
    pos += 8 + length;
  }
  if (pos != footer) return Status::Corruption(path + ": bytes after the last record");
  return Status::Ok();
}

StatusOr<std::unique_ptr<ThreeDtkScanSource>> ThreeDtkScanSource::Open(const std::string& dir) {
  GS_ASSIGN_OR_RETURN(std::vector<int> numbers, List3dtkScans(dir));
  auto source = std::make_unique<ThreeDtkScanSource>();
  source->dir_ = dir;
  source->numbers_ = std::move(numbers);
  return source;
}

Status ThreeDtkScanSource::Load(int64_t index, std::vector<Scan>* scans) const {
  if (index < 0 || index >= NumChunks()) return Status::InvalidArgument("scan chunk out of range");
  GS_ASSIGN_OR_RETURN(Scan scan, Read3dtkScan(dir_, numbers_[static_cast<size_t>(index)], index));
  scans->clear();
  scans->push_back(std::move(scan));
  return Status::Ok();
}

}  // namespace graphslam::map
