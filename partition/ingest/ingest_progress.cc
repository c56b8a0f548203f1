// Writer and reader of docs/formats/ingest_progress.md.
#include "partition/ingest/ingest_progress.h"

#include <nlohmann/json.hpp>
#include <string_view>

#include "storage/atomic_file.h"
#include "storage/checksummed_json.h"
#include "storage/chunk_format.h"
#include "storage/crc32c.h"
#include "storage/env.h"
#include "storage/file_checksum.h"

namespace graphslam::partition {
namespace {

namespace format = storage::chunk_format;

// "GSPASS1\n" read as a little-endian u64.
constexpr uint64_t kPass1Magic = 0x0A31535341505347ull;
constexpr uint32_t kPass1Version = 1;
constexpr size_t kPass1HeaderSize = 8 + 4 + 4 + 8 + 8 + 8;

// Appends `values` little-endian through `file`, extending *crc.
template <typename T>
Status AppendArray(storage::WritableFile* file, const std::vector<T>& values, uint32_t* crc) {
  std::string piece;
  for (size_t i = 0; i < values.size(); ++i) {
    if constexpr (sizeof(T) == 8) {
      format::PutFixed64(&piece, static_cast<uint64_t>(values[i]));
    } else {
      format::PutFixed32(&piece, static_cast<uint32_t>(values[i]));
    }
    if (piece.size() >= (1u << 20) || i + 1 == values.size()) {
      *crc = storage::crc32c::Extend(*crc, piece.data(), piece.size());
      GS_RETURN_IF_ERROR(file->Append(piece));
      piece.clear();
    }
  }
  return Status::Ok();
}

int64_t ReadInt(const nlohmann::json& object, const char* key, bool* ok) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_number_integer()) {
    *ok = false;
    return 0;
  }
  return it->get<int64_t>();
}

std::string ReadString(const nlohmann::json& object, const char* key, bool* ok) {
  const auto it = object.find(key);
  if (it == object.end() || !it->is_string()) {
    *ok = false;
    return "";
  }
  return it->get<std::string>();
}

}  // namespace

Status WritePass1Record(storage::Env* env, const std::string& path, const Pass1Record& record) {
  GS_CHECK(record.counts.size() == record.feature_ids.size() &&
           record.first_pose.size() == record.feature_ids.size());
  return storage::WriteFileAtomically(env, path, [&](storage::WritableFile* file) -> Status {
    std::string header;
    format::PutFixed64(&header, kPass1Magic);
    format::PutFixed32(&header, kPass1Version);
    format::PutFixed32(&header, 0);  // reserved
    format::PutFixed64(&header, record.pose_ids.size());
    format::PutFixed64(&header, record.feature_ids.size());
    format::PutFixed64(&header, static_cast<uint64_t>(record.observations));
    uint32_t crc = storage::crc32c::Value(header);
    GS_RETURN_IF_ERROR(file->Append(header));
    GS_RETURN_IF_ERROR(AppendArray(file, record.pose_ids, &crc));
    GS_RETURN_IF_ERROR(AppendArray(file, record.feature_ids, &crc));
    GS_RETURN_IF_ERROR(AppendArray(file, record.counts, &crc));
    GS_RETURN_IF_ERROR(AppendArray(file, record.first_pose, &crc));
    std::string footer;
    format::PutFixed32(&footer, storage::crc32c::Mask(crc));
    return file->Append(footer);
  });
}

StatusOr<Pass1Record> ReadPass1Record(const std::string& path) {
  StatusOr<std::string> read = storage::ReadFileToString(storage::Env::Default(), path);
  if (!read.ok())
    return read.status().IsNotFound() ? Status::NotFound(path + ": no first-pass record")
                                      : read.status();
  const std::string& bytes = read.value();
  if (bytes.size() < kPass1HeaderSize + 4)
    return Status::Corruption(path + ": " + std::to_string(bytes.size()) +
                              " bytes; expected at least a header and a crc");
  const char* p = bytes.data();
  if (format::DecodeFixed64(p) != kPass1Magic)
    return Status::Corruption(path + ": bad magic; expected a first-pass record");
  if (format::DecodeFixed32(p + 8) != kPass1Version)
    return Status::NotSupported(path + ": version " + std::to_string(format::DecodeFixed32(p + 8)) +
                                "; expected " + std::to_string(kPass1Version));
  const uint64_t poses = format::DecodeFixed64(p + 16);
  const uint64_t features = format::DecodeFixed64(p + 24);
  const uint64_t expected = kPass1HeaderSize + 8 * poses + 16 * features + 4;
  if (poses > bytes.size() || features > bytes.size() || bytes.size() != expected)
    return Status::Corruption(path + ": " + std::to_string(bytes.size()) + " bytes; expected " +
                              std::to_string(expected) + " for " + std::to_string(poses) +
                              " poses and " + std::to_string(features) + " features");
  const uint32_t stored = storage::crc32c::Unmask(format::DecodeFixed32(p + bytes.size() - 4));
  const uint32_t actual = storage::crc32c::Value(p, bytes.size() - 4);
  if (stored != actual) return Status::Corruption(path + ": crc mismatch");
  Pass1Record record;
  record.observations = static_cast<int64_t>(format::DecodeFixed64(p + 32));
  p += kPass1HeaderSize;
  record.pose_ids.resize(poses);
  for (auto& id : record.pose_ids) id = static_cast<int64_t>(format::DecodeFixed64(p)), p += 8;
  record.feature_ids.resize(features);
  for (auto& id : record.feature_ids) id = static_cast<int64_t>(format::DecodeFixed64(p)), p += 8;
  record.counts.resize(features);
  for (auto& n : record.counts) n = static_cast<int32_t>(format::DecodeFixed32(p)), p += 4;
  record.first_pose.resize(features);
  for (auto& n : record.first_pose) n = static_cast<int32_t>(format::DecodeFixed32(p)), p += 4;
  return record;
}

bool IngestProgress::SameIngest(const IngestProgress& other) const {
  return input == other.input && input_bytes == other.input_bytes &&
         input_crc32c == other.input_crc32c && chunk_observations == other.chunk_observations &&
         buffer_observations == other.buffer_observations && compression == other.compression &&
         zstd_level == other.zstd_level && target_record_bytes == other.target_record_bytes &&
         source == other.source &&
         replay_segment_observations == other.replay_segment_observations;
}

Status WriteIngestProgress(storage::Env* env, const std::string& path,
                           const IngestProgress& progress) {
  nlohmann::json json;
  json["format"] = kIngestProgressFormat;
  json["version"] = kIngestProgressVersion;
  json["input"] = progress.input;
  json["input_bytes"] = progress.input_bytes;
  json["input_crc32c"] = storage::FormatCrc32c(progress.input_crc32c);
  json["chunk_observations"] = progress.chunk_observations;
  json["buffer_observations"] = progress.buffer_observations;
  json["compression"] = progress.compression;
  json["zstd_level"] = progress.zstd_level;
  json["target_record_bytes"] = progress.target_record_bytes;
  json["source"] = progress.source;
  json["replay_segment_observations"] = progress.replay_segment_observations;
  json["poses"] = progress.poses;
  json["features"] = progress.features;
  json["observations"] = progress.observations;
  json["stage"] = progress.stage;
  json["spill"] = {{"replay_position", progress.spill.replay_position},
                   {"observations", progress.spill.observations},
                   {"bucket_observations", progress.spill.bucket_observations}};
  json["chunks_durable"] = progress.chunks_durable;
  storage::SealJson(&json);
  return storage::WriteStringAtomically(env, path, json.dump(1) + "\n");
}

StatusOr<IngestProgress> ReadIngestProgress(const std::string& path) {
  StatusOr<std::string> read = storage::ReadFileToString(storage::Env::Default(), path);
  if (!read.ok())
    return read.status().IsNotFound() ? Status::NotFound(path + ": no ingest progress")
                                      : read.status();
  const std::string& text = read.value();
  nlohmann::json json = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (json.is_discarded() || !json.is_object())
    return Status::Corruption(path + ": not a JSON object");
  bool ok = true;
  if (ReadString(json, "format", &ok) != kIngestProgressFormat || !ok)
    return Status::Corruption(path + ": \"format\" is not \"" +
                              std::string(kIngestProgressFormat) + "\"");
  if (ReadInt(json, "version", &ok) != kIngestProgressVersion)
    return Status::NotSupported(path + ": version is not " +
                                std::to_string(kIngestProgressVersion));
  GS_RETURN_IF_ERROR(storage::UnsealJson(&json, path));
  IngestProgress progress;
  progress.input = ReadString(json, "input", &ok);
  progress.input_bytes = ReadInt(json, "input_bytes", &ok);
  if (!storage::ParseCrc32c(ReadString(json, "input_crc32c", &ok), &progress.input_crc32c))
    ok = false;
  progress.chunk_observations = ReadInt(json, "chunk_observations", &ok);
  progress.buffer_observations = ReadInt(json, "buffer_observations", &ok);
  progress.compression = static_cast<int>(ReadInt(json, "compression", &ok));
  progress.zstd_level = static_cast<int>(ReadInt(json, "zstd_level", &ok));
  progress.target_record_bytes = ReadInt(json, "target_record_bytes", &ok);
  progress.source = ReadString(json, "source", &ok);
  progress.replay_segment_observations = ReadInt(json, "replay_segment_observations", &ok);
  progress.poses = static_cast<int32_t>(ReadInt(json, "poses", &ok));
  progress.features = static_cast<int32_t>(ReadInt(json, "features", &ok));
  progress.observations = ReadInt(json, "observations", &ok);
  progress.stage = ReadString(json, "stage", &ok);
  progress.chunks_durable = ReadInt(json, "chunks_durable", &ok);
  const auto spill = json.find("spill");
  if (spill == json.end() || !spill->is_object()) {
    ok = false;
  } else {
    progress.spill.replay_position = ReadInt(*spill, "replay_position", &ok);
    progress.spill.observations = ReadInt(*spill, "observations", &ok);
    const auto buckets = spill->find("bucket_observations");
    if (buckets == spill->end() || !buckets->is_array()) {
      ok = false;
    } else {
      for (const auto& value : *buckets) {
        if (!value.is_number_integer()) ok = false;
        progress.spill.bucket_observations.push_back(value.is_number_integer() ? value.get<int64_t>()
                                                                               : 0);
      }
    }
  }
  if (!ok) return Status::Corruption(path + ": a field is missing or has the wrong type");
  if (progress.stage != "spill" && progress.stage != "chunks")
    return Status::Corruption(path + ": stage is \"" + progress.stage +
                              "\"; expected \"spill\" or \"chunks\"");
  return progress;
}

}  // namespace graphslam::partition
