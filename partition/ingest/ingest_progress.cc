// Writer and reader of docs/formats/ingest_progress.md.
#include "partition/ingest/ingest_progress.h"

#include <nlohmann/json.hpp>
#include <algorithm>
#include <memory>
#include <string_view>
#include <utility>

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

namespace {

// Reads pass1.bin front to back in blocks of 1 MiB, extending the CRC32C of
// everything before the footer.
class Pass1Reader {
 public:
  Pass1Reader(std::string path, std::unique_ptr<storage::ReadableFile> file, uint64_t size)
      : path_(std::move(path)), file_(std::move(file)), left_(size - 4) {}

  // The next n bytes (n <= what is left before the footer), into *out.
  Status Next(size_t n, std::string* out) {
    out->resize(n);
    size_t got = 0;
    while (got < n) {
      GS_ASSIGN_OR_RETURN(const size_t read, file_->Read(n - got, out->data() + got));
      if (read == 0)
        return Status::Corruption(path_ + ": ends early; expected " + std::to_string(n - got) +
                                  " more bytes");
      got += read;
    }
    crc_ = storage::crc32c::Extend(crc_, out->data(), n);
    left_ -= n;
    return Status::Ok();
  }

  // `count` values of sizeof(T) bytes; kept in *values if it is not null.
  template <typename T>
  Status Array(uint64_t count, std::vector<T>* values) {
    constexpr uint64_t kPerBlock = (uint64_t{1} << 20) / sizeof(T);
    if (values != nullptr) values->reserve(count);
    std::string block;
    for (uint64_t done = 0; done < count;) {
      const uint64_t n = std::min(kPerBlock, count - done);
      GS_RETURN_IF_ERROR(Next(static_cast<size_t>(n * sizeof(T)), &block));
      if (values != nullptr) {
        for (const char* p = block.data(); p < block.data() + block.size(); p += sizeof(T)) {
          if constexpr (sizeof(T) == 8) {
            values->push_back(static_cast<T>(format::DecodeFixed64(p)));
          } else {
            values->push_back(static_cast<T>(format::DecodeFixed32(p)));
          }
        }
      }
      done += n;
    }
    return Status::Ok();
  }

  Status CheckFooter() {
    GS_CHECK(left_ == 0);
    std::string footer(4, '\0');
    GS_ASSIGN_OR_RETURN(const size_t read, file_->Read(4, footer.data()));
    if (read != 4) return Status::Corruption(path_ + ": ends early; expected the crc");
    if (storage::crc32c::Unmask(format::DecodeFixed32(footer.data())) != crc_)
      return Status::Corruption(path_ + ": crc mismatch");
    return Status::Ok();
  }

 private:
  const std::string path_;
  std::unique_ptr<storage::ReadableFile> file_;
  uint64_t left_ = 0;
  uint32_t crc_ = 0;
};

}  // namespace

StatusOr<Pass1Record> ReadPass1Record(const std::string& path) {
  storage::Env* env = storage::Env::Default();
  if (!env->FileExists(path)) return Status::NotFound(path + ": no first-pass record");
  GS_ASSIGN_OR_RETURN(std::unique_ptr<storage::ReadableFile> file, env->NewReadableFile(path));
  GS_ASSIGN_OR_RETURN(const uint64_t size, file->Size());
  if (size < kPass1HeaderSize + 4)
    return Status::Corruption(path + ": " + std::to_string(size) +
                              " bytes; expected at least a header and a crc");
  Pass1Reader reader(path, std::move(file), size);
  std::string header;
  GS_RETURN_IF_ERROR(reader.Next(kPass1HeaderSize, &header));
  const char* p = header.data();
  if (format::DecodeFixed64(p) != kPass1Magic)
    return Status::Corruption(path + ": bad magic; expected a first-pass record");
  if (format::DecodeFixed32(p + 8) != kPass1Version)
    return Status::NotSupported(path + ": version " + std::to_string(format::DecodeFixed32(p + 8)) +
                                "; expected " + std::to_string(kPass1Version));
  const uint64_t poses = format::DecodeFixed64(p + 16);
  const uint64_t features = format::DecodeFixed64(p + 24);
  if (poses > size || features > size || size != kPass1HeaderSize + 8 * poses + 16 * features + 4)
    return Status::Corruption(path + ": " + std::to_string(size) + " bytes; expected " +
                              std::to_string(kPass1HeaderSize + 8 * poses + 16 * features + 4) +
                              " for " + std::to_string(poses) + " poses and " +
                              std::to_string(features) + " features");
  Pass1Record record;
  record.observations = static_cast<int64_t>(format::DecodeFixed64(p + 32));
  GS_RETURN_IF_ERROR(reader.Array<int64_t>(poses, nullptr));
  GS_RETURN_IF_ERROR(reader.Array<int64_t>(features, nullptr));
  GS_RETURN_IF_ERROR(reader.Array<int32_t>(features, &record.counts));
  GS_RETURN_IF_ERROR(reader.Array<int32_t>(features, &record.first_pose));
  GS_RETURN_IF_ERROR(reader.CheckFooter());
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
