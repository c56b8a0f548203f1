#include "storage/chunk_store.h"

#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>
#include <system_error>
#include <utility>

#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/checksummed_json.h"
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

// Reads a "crc32c" string field; Corruption naming `where`.
Status ReadCrc(const nlohmann::json& object, const std::string& where, uint32_t* crc) {
  auto it = object.find("crc32c");
  if (it == object.end() || !it->is_string() || !ParseCrc32c(it->get<std::string>(), crc))
    return Status::Corruption(where + ": missing or malformed \"crc32c\" (8 hex digits)");
  return Status::Ok();
}

// A "files" path: relative, '/'-separated, no empty, "." or ".." part.
bool SafeRelativePath(const std::string& path) {
  if (path.empty() || path.front() == '/') return false;
  size_t begin = 0;
  while (begin <= path.size()) {
    const size_t end = std::min(path.find('/', begin), path.size());
    const std::string part = path.substr(begin, end - begin);
    if (part.empty() || part == "." || part == "..") return false;
    begin = end + 1;
  }
  return true;
}

// Size, then CRC32C of `path` against the manifest's `bytes` and `crc`.
Status CheckFileChecksum(const std::string& path, int64_t bytes, uint32_t crc) {
  GS_ASSIGN_OR_RETURN(FileChecksum actual, ChecksumFile(path));
  if (actual.bytes != bytes)
    return Status::Corruption(path + ": size is " + std::to_string(actual.bytes) +
                              " bytes; the manifest says " + std::to_string(bytes));
  if (actual.crc32c != crc)
    return Status::Corruption(path + ": crc32c is " + FormatCrc32c(actual.crc32c) +
                              "; the manifest says " + FormatCrc32c(crc) +
                              " (the file was damaged or edited)");
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

StatusOr<core::Problem2d> ReadChunkStoreProblem(const std::string& dir, bool with_features) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<DiskChunkSource> store, DiskChunkSource::Open(dir));
  const std::string path = Join(dir, kChunkStoreProblemName);
  std::error_code error;
  if (!std::filesystem::exists(path, error))
    return Status::NotFound(path + ": chunk store problem file missing");
  for (const ChunkStoreFile& file : store->files())
    if (file.path == kChunkStoreProblemName)
      GS_RETURN_IF_ERROR(CheckFileChecksum(path, file.bytes, file.crc32c));
  if (!with_features) {
    GS_ASSIGN_OR_RETURN(core::Problem2d problem, ReadNativeLogWithoutFeatures(path));
    if (!problem.observations.empty())
      return Status::Corruption(path + ": a chunk store problem holds no observations; found " +
                                std::to_string(problem.observations.size()));
    return problem;
  }
  // The file is the one the store's writer made (its CRC32C checked above
  // from manifest version 2 on): its FEATURE records are unique and no
  // record refers to a feature, so the reader builds no id table, and the
  // per-feature arrays are reserved to the manifest's count (never grown by
  // copying). A record referring to a feature is Corruption.
  ExpectedSizes expected;
  expected.features = store->total_features();
  expected.declared_once = true;
  return ReadNativeLogStreaming(
      path,
      [&path](const core::Observation&) {
        return Status::Corruption(path + ": a chunk store problem holds no observations; "
                                  "found one");
      },
      nullptr, expected);
}

Status VerifyChunkStoreFiles(const std::string& dir, const std::string& prefix) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<DiskChunkSource> store, DiskChunkSource::Open(dir));
  for (const ChunkStoreFile& file : store->files())
    if (file.path.compare(0, prefix.size(), prefix) == 0)
      GS_RETURN_IF_ERROR(CheckFileChecksum(Join(dir, file.path), file.bytes, file.crc32c));
  return Status::Ok();
}

namespace {

// The manifest's JSON object (not yet checked).
StatusOr<nlohmann::json> ReadManifest(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::IOError(path + ": cannot open for reading");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) return Status::IOError(path + ": read failed");
  nlohmann::json manifest = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (manifest.is_discarded() || !manifest.is_object())
    return Status::Corruption(path + ": not a JSON object");
  return manifest;
}

// The format and a version this build reads; from version 2 the manifest
// checks itself (its seal) before any field is trusted. Returns the version.
StatusOr<int64_t> CheckManifestVersion(nlohmann::json* manifest, const std::string& path) {
  auto format = manifest->find("format");
  if (format == manifest->end() || !format->is_string() ||
      format->get<std::string>() != kChunkStoreFormatName)
    return Status::Corruption(path + ": \"format\" is not \"" +
                              std::string(kChunkStoreFormatName) + "\"");
  int64_t version = 0;
  GS_RETURN_IF_ERROR(ReadCount(*manifest, "version", path, &version));
  if (version > kChunkStoreVersion)
    return Status::NotSupported(path + ": chunk store version " + std::to_string(version) +
                                "; this build reads up to " + std::to_string(kChunkStoreVersion));
  if (version < 1)
    return Status::Corruption(path + ": chunk store version " + std::to_string(version) +
                              "; expected >= 1");
  if (version >= 2) {
    GS_RETURN_IF_ERROR(UnsealJson(manifest, path));
  } else if (manifest->contains(kJsonChecksumKey) || manifest->contains("files")) {
    // A version 2 manifest edited down to version 1 would skip every check.
    return Status::Corruption(path + ": \"version\" is 1 but the manifest has version 2 "
                              "fields (\"checksum\", \"files\"): it was edited or damaged");
  } else {
    GS_LOG(WARNING, "%s: chunk store version 1: its files carry no checksums, so damage to "
           "problem.graphslam or an edited manifest goes undetected; run graphslam ingest "
           "again to make a version %d store", path.c_str(), kChunkStoreVersion);
  }
  return version;
}

// Entry k of "chunks": its file (exactly ChunkStoreFileName(k): no path may
// escape STORE/chunks, and order is position), counts and (version 2) CRC.
StatusOr<ChunkStoreEntry> ReadChunkEntry(const nlohmann::json& item, int64_t k,
                                         const std::string& path, int64_t version) {
  const std::string where = path + ": chunks[" + std::to_string(k) + "]";
  if (!item.is_object()) return Status::Corruption(where + ": not an object");
  ChunkStoreEntry entry;
  auto file = item.find("file");
  if (file == item.end() || !file->is_string())
    return Status::Corruption(where + ": missing \"file\"");
  entry.file = file->get<std::string>();
  if (entry.file != ChunkStoreFileName(k))
    return Status::Corruption(where + ": file is \"" + entry.file + "\"; expected \"" +
                              ChunkStoreFileName(k) + "\"");
  GS_RETURN_IF_ERROR(ReadCount(item, "features", where, &entry.features));
  GS_RETURN_IF_ERROR(ReadCount(item, "observations", where, &entry.observations));
  GS_RETURN_IF_ERROR(ReadCount(item, "bytes", where, &entry.bytes));
  if (version >= 2) GS_RETURN_IF_ERROR(ReadCrc(item, where, &entry.crc32c));
  return entry;
}

}  // namespace

StatusOr<std::unique_ptr<DiskChunkSource>> DiskChunkSource::Open(const std::string& dir) {
  GS_RETURN_IF_ERROR(CheckComplete(dir));
  const std::string path = Join(dir, kChunkStoreManifestName);
  GS_ASSIGN_OR_RETURN(nlohmann::json manifest, ReadManifest(path));
  GS_ASSIGN_OR_RETURN(const int64_t version, CheckManifestVersion(&manifest, path));

  std::unique_ptr<DiskChunkSource> source(new DiskChunkSource());
  source->dir_ = dir;
  source->version_ = static_cast<int>(version);
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
    GS_ASSIGN_OR_RETURN(ChunkStoreEntry entry,
                        ReadChunkEntry((*chunks)[static_cast<size_t>(k)], k, path, version));
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
  if (version >= 2) GS_RETURN_IF_ERROR(source->ReadVersion2Fields(manifest, path));
  source->checked_ = std::make_unique<std::atomic<uint8_t>[]>(source->entries_.size());
  for (size_t k = 0; k < source->entries_.size(); ++k) source->checked_[k] = 0;
  return source;
}

Status DiskChunkSource::ReadVersion2Fields(const nlohmann::json& manifest, const std::string& path) {
  auto input = manifest.find("input");
  if (input == manifest.end() || !(input->is_null() || input->is_object()))
    return Status::Corruption(path + ": missing \"input\" (an object, or null)");
  if (input->is_object()) {
    GS_RETURN_IF_ERROR(ReadCount(*input, "bytes", path + ": input", &input_.bytes));
    GS_RETURN_IF_ERROR(ReadCrc(*input, path + ": input", &input_.crc32c));
  }
  auto files = manifest.find("files");
  if (files == manifest.end() || !files->is_array())
    return Status::Corruption(path + ": missing \"files\" array");
  bool problem_listed = false;
  for (size_t i = 0; i < files->size(); ++i) {
    const nlohmann::json& item = (*files)[i];
    const std::string where = path + ": files[" + std::to_string(i) + "]";
    if (!item.is_object()) return Status::Corruption(where + ": not an object");
    ChunkStoreFile file;
    auto name = item.find("path");
    if (name == item.end() || !name->is_string() || !SafeRelativePath(name->get<std::string>()))
      return Status::Corruption(where + ": missing \"path\", or not a relative path inside "
                                "the store");
    file.path = name->get<std::string>();
    GS_RETURN_IF_ERROR(ReadCount(item, "bytes", where, &file.bytes));
    GS_RETURN_IF_ERROR(ReadCrc(item, where, &file.crc32c));
    problem_listed = problem_listed || file.path == kChunkStoreProblemName;
    // Present and of its size now; the CRC32C when the file is read.
    const std::string full = Join(dir_, file.path);
    std::error_code error;
    const std::uintmax_t bytes = std::filesystem::file_size(full, error);
    if (error)
      return Status::NotFound(full + ": listed in " + path + " but missing (" +
                              error.message() + ")");
    if (static_cast<int64_t>(bytes) != file.bytes)
      return Status::Corruption(full + ": size is " + std::to_string(bytes) +
                                " bytes; the manifest says " + std::to_string(file.bytes));
    files_.push_back(std::move(file));
  }
  if (!problem_listed)
    return Status::Corruption(path + ": \"files\" does not list " +
                              std::string(kChunkStoreProblemName));
  // Optional: the shards of a distributed ingest, ranks 0..N-1 covering the
  // chunks in order.
  if (auto shards = manifest.find("shards"); shards != manifest.end()) {
    if (!shards->is_array()) return Status::Corruption(path + ": \"shards\" is not an array");
    int64_t next = 0;
    for (size_t r = 0; r < shards->size(); ++r) {
      const nlohmann::json& item = (*shards)[r];
      const std::string where = path + ": shards[" + std::to_string(r) + "]";
      if (!item.is_object()) return Status::Corruption(where + ": not an object");
      int64_t rank = 0;
      ChunkStoreShard shard;
      GS_RETURN_IF_ERROR(ReadCount(item, "rank", where, &rank));
      GS_RETURN_IF_ERROR(ReadCount(item, "first_chunk", where, &shard.first_chunk));
      GS_RETURN_IF_ERROR(ReadCount(item, "chunks", where, &shard.chunks));
      if (rank != static_cast<int64_t>(r) || shard.first_chunk != next)
        return Status::Corruption(where + ": rank " + std::to_string(rank) + ", first_chunk " +
                                  std::to_string(shard.first_chunk) + "; expected rank " +
                                  std::to_string(r) + ", first_chunk " + std::to_string(next));
      shard.rank = static_cast<int>(rank);
      next += shard.chunks;
      shards_.push_back(shard);
    }
    if (next != static_cast<int64_t>(entries_.size()))
      return Status::Corruption(path + ": \"shards\" cover " + std::to_string(next) +
                                " chunks; the store has " + std::to_string(entries_.size()));
  }
  // Chunk files present and of their size now (a missing one fails here,
  // not in the middle of a solve).
  for (const ChunkStoreEntry& entry : entries_) {
    const std::string chunk = ChunkPath(dir_, entry.file);
    std::error_code error;
    const std::uintmax_t bytes = std::filesystem::file_size(chunk, error);
    if (error)
      return Status::NotFound(chunk + ": chunk file missing (listed in " + path + ")");
    if (static_cast<int64_t>(bytes) != entry.bytes)
      return Status::Corruption(chunk + ": size is " + std::to_string(bytes) +
                                " bytes; the manifest says " + std::to_string(entry.bytes));
  }
  return Status::Ok();
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
  if (version_ >= 2 && checked_[static_cast<size_t>(index)].load() == 0) {
    GS_RETURN_IF_ERROR(CheckFileChecksum(path, entry.bytes, entry.crc32c));
    checked_[static_cast<size_t>(index)] = 1;
  }
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
