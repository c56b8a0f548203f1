#include "storage/chunk_store.h"

#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>
#include <utility>

#include "storage/atomic_file.h"
#include "storage/chunk_reader.h"
#include "storage/chunk_store_writer.h"
#include "storage/native_log_reader.h"

namespace graphslam::storage {
namespace {

std::string Join(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

std::string ChunkPath(const std::string& dir, const std::string& file) {
  return Join(Join(dir, kChunkStoreChunkDirectory), file);
}

// Reads an integer field >= 0 of `object`; Corruption naming `where` and `key`.
Status ReadCount(const nlohmann::json& object, const char* key, const std::string& where,
                 int64_t* value) {
  auto it = object.find(key);
  if (it == object.end() || !it->is_number_integer())
    return Status::Corruption(where + ": missing or non-integer \"" + key + "\"");
  *value = it->get<int64_t>();
  if (*value < 0)
    return Status::Corruption(where + ": \"" + key + "\" must be >= 0, got " +
                              std::to_string(*value));
  return Status::Ok();
}

Status CheckComplete(const std::string& dir) {
  std::error_code error;
  if (!std::filesystem::is_directory(dir, error))
    return Status::NotFound(dir + ": no such chunk store directory");
  if (!std::filesystem::exists(Join(dir, kChunkStoreManifestName), error))
    return Status::Corruption(dir + ": incomplete chunk store: no " +
                              std::string(kChunkStoreManifestName) +
                              " (the ingest did not finish; run graphslam ingest again)");
  return Status::Ok();
}

}  // namespace

std::string ChunkStoreFileName(int64_t index) {
  char name[32];
  std::snprintf(name, sizeof(name), "%06" PRId64 ".gsc", index);
  return name;
}

Status WriteChunkStore(Env* env, const std::string& dir, const core::Problem2d& problem,
                       const core::ChunkSource& chunks, const ChunkStoreWriteOptions& options) {
  GS_CHECK(env != nullptr);
  GS_RETURN_IF_ERROR(options.Validate());
  ChunkStoreWriter writer(env, dir, options);
  GS_RETURN_IF_ERROR(writer.Uncommit());
  GS_RETURN_IF_ERROR(writer.WriteProblem(problem));
  GS_RETURN_IF_ERROR(writer.WriteChunks(chunks, 0, nullptr));
  return writer.Commit();
}

bool IsChunkStore(const std::string& path) {
  std::error_code error;
  return std::filesystem::is_directory(path, error) &&
         std::filesystem::is_regular_file(Join(path, kChunkStoreManifestName), error);
}

StatusOr<core::Problem2d> ReadChunkStoreProblem(const std::string& dir) {
  GS_RETURN_IF_ERROR(CheckComplete(dir));
  const std::string path = Join(dir, kChunkStoreProblemName);
  std::error_code error;
  if (!std::filesystem::exists(path, error))
    return Status::NotFound(path + ": chunk store problem file missing");
  GS_ASSIGN_OR_RETURN(core::Problem2d problem, ReadNativeLog(path));
  if (!problem.observations.empty())
    return Status::Corruption(path + ": a chunk store problem holds no observations; found " +
                              std::to_string(problem.observations.size()));
  return problem;
}

StatusOr<std::unique_ptr<DiskChunkSource>> DiskChunkSource::Open(const std::string& dir) {
  GS_RETURN_IF_ERROR(CheckComplete(dir));
  const std::string path = Join(dir, kChunkStoreManifestName);
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::IOError(path + ": cannot open for reading");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return Status::IOError(path + ": read failed");
  const nlohmann::json manifest = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (manifest.is_discarded() || !manifest.is_object())
    return Status::Corruption(path + ": not a JSON object");

  auto format = manifest.find("format");
  if (format == manifest.end() || !format->is_string() ||
      format->get<std::string>() != kChunkStoreFormatName)
    return Status::Corruption(path + ": \"format\" is not \"" +
                              std::string(kChunkStoreFormatName) + "\"");
  int64_t version = 0;
  GS_RETURN_IF_ERROR(ReadCount(manifest, "version", path, &version));
  if (version > kChunkStoreVersion)
    return Status::NotSupported(path + ": chunk store version " + std::to_string(version) +
                                "; this build reads up to " + std::to_string(kChunkStoreVersion));
  if (version < 1)
    return Status::Corruption(path + ": chunk store version " + std::to_string(version) +
                              "; expected >= 1");

  std::unique_ptr<DiskChunkSource> source(new DiskChunkSource());
  source->dir_ = dir;
  if (auto it = manifest.find("source"); it != manifest.end() && it->is_string())
    source->source_ = it->get<std::string>();
  int64_t num_chunks = 0;
  GS_RETURN_IF_ERROR(ReadCount(manifest, "num_chunks", path, &num_chunks));
  auto chunks = manifest.find("chunks");
  if (chunks == manifest.end() || !chunks->is_array())
    return Status::Corruption(path + ": missing \"chunks\" array");
  if (static_cast<int64_t>(chunks->size()) != num_chunks)
    return Status::Corruption(path + ": \"chunks\" lists " + std::to_string(chunks->size()) +
                              " entries; expected num_chunks = " + std::to_string(num_chunks));
  source->entries_.reserve(chunks->size());
  for (int64_t k = 0; k < num_chunks; ++k) {
    const nlohmann::json& item = (*chunks)[static_cast<size_t>(k)];
    const std::string where = path + ": chunks[" + std::to_string(k) + "]";
    if (!item.is_object()) return Status::Corruption(where + ": not an object");
    ChunkStoreEntry entry;
    auto file = item.find("file");
    if (file == item.end() || !file->is_string())
      return Status::Corruption(where + ": missing \"file\"");
    entry.file = file->get<std::string>();
    // Exact name: no path may escape STORE/chunks, and order is position.
    if (entry.file != ChunkStoreFileName(k))
      return Status::Corruption(where + ": file is \"" + entry.file + "\"; expected \"" +
                                ChunkStoreFileName(k) + "\"");
    GS_RETURN_IF_ERROR(ReadCount(item, "features", where, &entry.features));
    GS_RETURN_IF_ERROR(ReadCount(item, "observations", where, &entry.observations));
    GS_RETURN_IF_ERROR(ReadCount(item, "bytes", where, &entry.bytes));
    source->total_features_ += entry.features;
    source->total_observations_ += entry.observations;
    source->total_bytes_ += entry.bytes;
    source->entries_.push_back(std::move(entry));
  }
  const std::pair<const char*, int64_t> totals[] = {
      {"total_features", source->total_features_},
      {"total_observations", source->total_observations_},
      {"total_bytes", source->total_bytes_}};
  for (const auto& [key, sum] : totals) {
    int64_t value = 0;
    GS_RETURN_IF_ERROR(ReadCount(manifest, key, path, &value));
    if (value != sum)
      return Status::Corruption(path + ": \"" + key + "\" is " + std::to_string(value) +
                                "; the chunk entries sum to " + std::to_string(sum));
  }
  return source;
}

Status DiskChunkSource::Load(int64_t index, core::ObservationChunk* chunk) const {
  GS_CHECK(chunk != nullptr);
  if (index < 0 || index >= NumChunks())
    return Status::InvalidArgument("chunk " + std::to_string(index) +
                                   " out of range; expected 0.." + std::to_string(NumChunks() - 1));
  const ChunkStoreEntry& entry = entries_[static_cast<size_t>(index)];
  const std::string path = ChunkPath(dir_, entry.file);
  std::error_code error;
  if (!std::filesystem::exists(path, error))
    return Status::NotFound(path + ": chunk file missing (listed in " +
                            std::string(kChunkStoreManifestName) + ")");
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  if (error) return Status::IOError(path + ": stat: " + error.message());
  if (static_cast<int64_t>(bytes) != entry.bytes)
    return Status::Corruption(path + ": size is " + std::to_string(bytes) +
                              " bytes; the manifest says " + std::to_string(entry.bytes));
  core::ObservationChunk read;
  Status status = ReadObservationChunk(path, &read);
  if (!status.ok()) return status.WithContext(path);
  if (read.index != index)
    return Status::Corruption(path + ": header chunk index is " + std::to_string(read.index) +
                              "; expected " + std::to_string(index));
  if (read.num_features() != entry.features)
    return Status::Corruption(path + ": " + std::to_string(read.num_features()) +
                              " features; the manifest says " + std::to_string(entry.features));
  if (static_cast<int64_t>(read.observations.size()) != entry.observations)
    return Status::Corruption(path + ": " + std::to_string(read.observations.size()) +
                              " observations; the manifest says " +
                              std::to_string(entry.observations));
  *chunk = std::move(read);
  return Status::Ok();
}

}  // namespace graphslam::storage
