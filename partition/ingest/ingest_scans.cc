#include "partition/ingest/ingest_scans.h"

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <system_error>
#include <utility>

#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/checksummed_json.h"
#include "storage/chunk_format.h"
#include "storage/crc32c.h"
#include "storage/env.h"
#include "storage/native_log_scans.h"
#include "storage/scan_store.h"
#include "storage/stop_point.h"

namespace graphslam::partition {
namespace {

namespace fs = std::filesystem;
namespace format = storage::chunk_format;

// "GSSCANR\n" read as a little-endian u64.
constexpr uint64_t kRecordsMagic = 0x0A524E4143535347ull;
constexpr uint32_t kRecordsVersion = 1;
constexpr const char* kProgressFormat = "graphslam-ingest-scans";
// 2: the record carries its own checksum (storage/checksummed_json.h); a
// version 1 record is not resumed (the scan copy restarts).
constexpr int kProgressVersion = 2;

struct ScanRecords {
  std::vector<storage::NativeLogScan> records;
  std::vector<core::Pose3> poses;
};

// scan_records.bin: magic u64, version u32, reserved u32, count u64, then per
// record: pose i32, line i32, qw qx qy qz tx ty tz f64, path length u32, path
// bytes; masked crc32c of all bytes before it (docs/formats/ingest_progress.md).
std::string EncodeRecords(const std::vector<storage::NativeLogScan>& records,
                          const std::vector<core::Pose3>& poses) {
  std::string out;
  format::PutFixed64(&out, kRecordsMagic);
  format::PutFixed32(&out, kRecordsVersion);
  format::PutFixed32(&out, 0);
  format::PutFixed64(&out, records.size());
  for (size_t i = 0; i < records.size(); ++i) {
    format::PutFixed32(&out, static_cast<uint32_t>(records[i].pose));
    format::PutFixed32(&out, static_cast<uint32_t>(records[i].line));
    const core::Pose3& p = poses[i];
    for (const double v : {p.q.w(), p.q.x(), p.q.y(), p.q.z(), p.t.x(), p.t.y(), p.t.z()})
      format::PutDouble(&out, v);
    format::PutFixed32(&out, static_cast<uint32_t>(records[i].file.size()));
    out += records[i].file;
  }
  format::PutFixed32(&out, storage::crc32c::Mask(storage::crc32c::Value(out)));
  return out;
}

StatusOr<ScanRecords> ReadRecords(const std::string& path) {
  StatusOr<std::string> read = storage::ReadFileToString(storage::Env::Default(), path);
  if (!read.ok())
    return read.status().IsNotFound() ? Status::NotFound(path + ": cannot open") : read.status();
  const std::string& bytes = read.value();
  constexpr size_t kHeader = 8 + 4 + 4 + 8;
  if (bytes.size() < kHeader + 4)
    return Status::Corruption(path + ": " + std::to_string(bytes.size()) +
                              " bytes; expected at least a header and a crc");
  const char* p = bytes.data();
  const uint32_t stored = storage::crc32c::Unmask(format::DecodeFixed32(p + bytes.size() - 4));
  if (stored != storage::crc32c::Value(p, bytes.size() - 4))
    return Status::Corruption(path + ": crc mismatch");
  if (format::DecodeFixed64(p) != kRecordsMagic) return Status::Corruption(path + ": bad magic");
  if (format::DecodeFixed32(p + 8) != kRecordsVersion)
    return Status::NotSupported(path + ": version " + std::to_string(format::DecodeFixed32(p + 8)) +
                                "; expected " + std::to_string(kRecordsVersion));
  const uint64_t count = format::DecodeFixed64(p + 16);
  ScanRecords out;
  size_t at = kHeader;
  const size_t end = bytes.size() - 4;
  for (uint64_t i = 0; i < count; ++i) {
    if (at + 4 + 4 + 56 + 4 > end) return Status::Corruption(path + ": truncated record " + std::to_string(i));
    storage::NativeLogScan record;
    record.pose = static_cast<int32_t>(format::DecodeFixed32(p + at));
    record.line = static_cast<int32_t>(format::DecodeFixed32(p + at + 4));
    double v[7];
    for (int k = 0; k < 7; ++k) v[k] = format::DecodeDouble(p + at + 8 + 8 * k);
    const uint32_t length = format::DecodeFixed32(p + at + 64);
    at += 68;
    if (at + length > end) return Status::Corruption(path + ": truncated record " + std::to_string(i));
    record.file.assign(p + at, length);
    at += length;
    core::Pose3 pose;
    pose.q = Eigen::Quaterniond(v[0], v[1], v[2], v[3]);
    pose.t = Eigen::Vector3d(v[4], v[5], v[6]);
    out.records.push_back(std::move(record));
    out.poses.push_back(pose);
  }
  if (at != end) return Status::Corruption(path + ": bytes after the last record");
  return out;
}

struct ScanProgress {
  int64_t scan_chunk_bytes = 0;
  int64_t records = 0;
  std::vector<map::ScanStoreWriter::Entry> chunks;
};

Status WriteProgress(storage::Env* env, const std::string& path, const ScanProgress& progress) {
  nlohmann::json chunks = nlohmann::json::array();
  for (const map::ScanStoreWriter::Entry& e : progress.chunks)
    chunks.push_back({{"file", e.file}, {"scans", e.scans}, {"points", e.points}, {"bytes", e.bytes}});
  nlohmann::json json = {{"format", kProgressFormat},
                         {"version", kProgressVersion},
                         {"scan_chunk_bytes", progress.scan_chunk_bytes},
                         {"records", progress.records},
                         {"chunks", chunks}};
  storage::SealJson(&json);
  return storage::WriteStringAtomically(env, path, json.dump(1) + "\n");
}

StatusOr<ScanProgress> ReadProgress(const std::string& path) {
  StatusOr<std::string> read = storage::ReadFileToString(storage::Env::Default(), path);
  if (!read.ok())
    return read.status().IsNotFound() ? Status::NotFound(path + ": no scan progress")
                                      : read.status();
  try {
    nlohmann::json json = nlohmann::json::parse(read.value());
    if (json.at("format").get<std::string>() != kProgressFormat)
      return Status::Corruption(path + ": format is not " + kProgressFormat);
    if (json.at("version").get<int>() != kProgressVersion)
      return Status::NotSupported(path + ": version " + json.at("version").dump());
    GS_RETURN_IF_ERROR(storage::UnsealJson(&json, path));
    ScanProgress progress;
    progress.scan_chunk_bytes = json.at("scan_chunk_bytes").get<int64_t>();
    progress.records = json.at("records").get<int64_t>();
    for (const nlohmann::json& c : json.at("chunks"))
      progress.chunks.push_back({c.at("file").get<std::string>(), c.at("scans").get<int64_t>(),
                                 c.at("points").get<int64_t>(), c.at("bytes").get<int64_t>()});
    return progress;
  } catch (const nlohmann::json::exception& error) {
    return Status::Corruption(path + ": " + error.what());
  }
}

// Whether the recorded chunks are on disk with their recorded sizes.
bool ChunksOnDisk(storage::Env* env, const std::string& scans_dir, const ScanProgress& progress) {
  for (const map::ScanStoreWriter::Entry& e : progress.chunks) {
    const StatusOr<uint64_t> size = env->FileSize((fs::path(scans_dir) / e.file).string());
    if (!size.ok() || static_cast<int64_t>(*size) != e.bytes) return false;
  }
  return true;
}

// Removes every file of `scans_dir` but the first `keep` chunks.
Status RemoveAllBut(storage::Env* env, const std::string& scans_dir,
                    const std::vector<map::ScanStoreWriter::Entry>& keep) {
  if (!env->FileExists(scans_dir)) return Status::Ok();
  GS_ASSIGN_OR_RETURN(const std::vector<std::string> names, env->ListDir(scans_dir));
  for (const std::string& name : names) {
    bool kept = false;
    for (const map::ScanStoreWriter::Entry& e : keep) kept = kept || e.file == name;
    if (!kept) GS_RETURN_IF_ERROR(env->RemoveTree((fs::path(scans_dir) / name).string()));
  }
  return Status::Ok();
}

}  // namespace

std::vector<core::Pose3> LoggedScanPoses(const core::Problem2d& problem,
                                         const std::vector<storage::NativeLogScan>& records) {
  std::vector<core::Pose3> poses;
  poses.reserve(records.size());
  for (const storage::NativeLogScan& record : records)
    poses.push_back(map::LiftLoggedPose(problem.poses[static_cast<size_t>(record.pose)]));
  return poses;
}

Status SaveScanRecords(storage::Env* env, const std::string& log_path, const std::string& work_dir,
                       const std::vector<storage::NativeLogScan>& records,
                       const std::vector<core::Pose3>& poses) {
  GS_CHECK(records.size() == poses.size());
  // Every file exists (the source's own check), before anything of the scans is written.
  GS_ASSIGN_OR_RETURN(std::unique_ptr<map::NativeLogScanSource> source,
                      map::NativeLogScanSource::FromRecords(log_path, records, poses));
  // No file without scans: a log without SCAN records ingests as before.
  if (records.empty()) return Status::Ok();
  return storage::WriteStringAtomically(env, (fs::path(work_dir) / kScanRecordsName).string(),
                                        EncodeRecords(records, poses));
}

Status RemoveIngestedScans(storage::Env* env, const std::string& store_dir) {
  return env->RemoveTree((fs::path(store_dir) / map::kScanStoreDirectory).string());
}

Status IngestScans(storage::Env* env, const std::string& log_path, const std::string& store_dir,
                   int64_t scan_chunk_bytes, bool resume, ScanIngestSummary* summary) {
  GS_CHECK(summary != nullptr);
  *summary = ScanIngestSummary();
  const fs::path work = fs::path(store_dir) / "work";  // kIngestWorkDirectory
  const std::string records_path = (work / kScanRecordsName).string();
  const std::string progress_path = (work / kScanProgressName).string();
  const std::string scans_dir = (fs::path(store_dir) / map::kScanStoreDirectory).string();
  // No record file: not a native log.
  if (!env->FileExists(records_path)) return RemoveIngestedScans(env, store_dir);
  GS_ASSIGN_OR_RETURN(ScanRecords read, ReadRecords(records_path));
  const auto num_records = static_cast<int64_t>(read.records.size());
  if (num_records == 0) return RemoveIngestedScans(env, store_dir);
  GS_ASSIGN_OR_RETURN(std::unique_ptr<map::NativeLogScanSource> source,
                      map::NativeLogScanSource::FromRecords(log_path, std::move(read.records),
                                                            std::move(read.poses)));

  ScanProgress progress;
  progress.scan_chunk_bytes = scan_chunk_bytes;
  progress.records = num_records;
  std::unique_ptr<map::ScanStoreWriter> writer;
  int64_t next = 0;
  if (resume) {
    StatusOr<ScanProgress> recorded = ReadProgress(progress_path);
    if (recorded.ok() && recorded->scan_chunk_bytes == scan_chunk_bytes &&
        recorded->records == num_records && ChunksOnDisk(env, scans_dir, *recorded)) {
      GS_RETURN_IF_ERROR(RemoveAllBut(env, scans_dir, recorded->chunks));
      for (const map::ScanStoreWriter::Entry& e : recorded->chunks) next += e.scans;
      progress.chunks = recorded->chunks;
      GS_ASSIGN_OR_RETURN(writer, map::ScanStoreWriter::Resume(store_dir, scan_chunk_bytes,
                                                               std::move(recorded).value().chunks));
      summary->resumed_from_scan = next;
    } else if (env->FileExists(progress_path) || env->FileExists(scans_dir)) {
      GS_LOG(WARNING, "%s: the scan copy restarts from the first scan (%s)", store_dir.c_str(),
             recorded.ok() ? "other options, or recorded chunks are missing"
                           : recorded.status().ToString().c_str());
    }
  }
  if (writer == nullptr) {
    GS_RETURN_IF_ERROR(RemoveIngestedScans(env, store_dir));
    GS_ASSIGN_OR_RETURN(writer, map::ScanStoreWriter::Create(store_dir, scan_chunk_bytes));
  }

  std::vector<map::Scan> scan;
  for (int64_t i = next; i < num_records; ++i) {
    GS_RETURN_IF_ERROR(source->Load(i, &scan));  // one record is one scan
    const size_t durable = writer->entries().size();
    GS_RETURN_IF_ERROR(writer->Add(scan.front()));
    if (writer->entries().size() != durable) {
      progress.chunks = writer->entries();
      GS_RETURN_IF_ERROR(WriteProgress(env, progress_path, progress));
      storage::StopPointAtCountForTests("ingest_scan_chunks",
                                        static_cast<long long>(progress.chunks.size()));
    }
  }
  GS_RETURN_IF_ERROR(writer->Finish());
  for (const map::ScanStoreWriter::Entry& e : writer->entries()) {
    summary->scans += e.scans;
    summary->points += e.points;
  }
  summary->chunks = static_cast<int64_t>(writer->entries().size());
  return Status::Ok();
}

}  // namespace graphslam::partition
