#include "storage/chunk_store_writer.h"

#include <tbb/parallel_pipeline.h>

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <system_error>
#include <thread>
#include <utility>

#include "core/logging.h"
#include "storage/atomic_file.h"
#include "storage/checksummed_json.h"
#include "storage/chunk_format.h"
#include "storage/chunk_writer.h"
#include "storage/crc32c.h"
#include "storage/directory_lock.h"
#include "storage/file_checksum.h"
#include "storage/internal/text_blocks.h"
#include "storage/native_log_reader.h"
#include "storage/scan_store.h"
#include "storage/store_directory.h"

namespace graphslam::storage {
namespace {

std::string Join(const std::string& dir, const std::string& name) {
  return (std::filesystem::path(dir) / name).string();
}

// A chunk file written but not yet durable.
struct PendingFile {
  std::string path;
  std::string temporary;
  std::unique_ptr<WritableFile> file;
};

// Sync and Close every file of `group`, up to kMaxSyncThreads at a time;
// returns the first error in group order.
Status SyncAndCloseConcurrently(std::vector<PendingFile>* group, int max_threads) {
  std::vector<Status> statuses(group->size());
  std::atomic<size_t> next{0};
  auto work = [&]() {
    for (size_t i = next++; i < group->size(); i = next++) {
      WritableFile* file = (*group)[i].file.get();
      Status status = file->Sync();
      if (status.ok()) {
        status = file->Close();
      } else {
        (void)file->Close();  // the first error is the one reported
      }
      statuses[i] = std::move(status);
    }
  };
  const size_t threads = std::min<size_t>(group->size(), static_cast<size_t>(max_threads));
  std::vector<std::thread> pool;
  for (size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (std::thread& thread : pool) thread.join();
  for (size_t i = 0; i < group->size(); ++i) {
    (*group)[i].file.reset();
    if (!statuses[i].ok()) return statuses[i].WithContext("writing " + (*group)[i].path);
  }
  return Status::Ok();
}

// The "files" of the manifest: problem.graphslam and every regular file
// below STORE/scans/ (sorted, temporaries skipped), with sizes and CRC32Cs.
StatusOr<nlohmann::json> ListStoreFiles(const std::string& dir) {
  namespace fs = std::filesystem;
  std::vector<std::string> paths = {kChunkStoreProblemName};
  const fs::path scans = fs::path(dir) / map::kScanStoreDirectory;
  std::error_code error;
  if (fs::is_directory(scans, error)) {
    std::vector<std::string> found;
    for (fs::recursive_directory_iterator it(scans, error), end; !error && it != end;
         it.increment(error)) {
      if (it->is_regular_file(error) && !IsTemporaryFileName(it->path().filename().string()) &&
          it->path().filename() != kDirectoryLockName)
        found.push_back(fs::relative(it->path(), dir, error).generic_string());
    }
    if (error) return Status::IOError(scans.string() + ": list: " + error.message());
    std::sort(found.begin(), found.end());
    paths.insert(paths.end(), found.begin(), found.end());
  }
  nlohmann::json files = nlohmann::json::array();
  for (const std::string& path : paths) {
    GS_ASSIGN_OR_RETURN(FileChecksum sum, ChecksumFile(Join(dir, path)));
    files.push_back({{"path", path}, {"bytes", sum.bytes}, {"crc32c", FormatCrc32c(sum.crc32c)}});
  }
  return files;
}

void RemoveTemporaries(Env* env, std::vector<PendingFile>* group) {
  for (PendingFile& pending : *group) {
    pending.file.reset();
    if (env->FileExists(pending.temporary) && !env->RemoveFile(pending.temporary).ok())
      GS_LOG(WARNING, "could not remove temporary file %s", pending.temporary.c_str());
  }
  group->clear();
}

// Chunk `index` of `chunks`, which must say it is chunk `index`.
Status LoadChunkAt(const core::ChunkSource& chunks, int64_t index, core::ObservationChunk* chunk) {
  GS_RETURN_IF_ERROR(chunks.Load(index, chunk));
  if (chunk->index == index) return Status::Ok();
  return Status::InvalidArgument("chunk at position " + std::to_string(index) + " has index " +
                                 std::to_string(chunk->index) + "; expected " +
                                 std::to_string(index));
}

// The manifest entry of an encoded chunk (chunk_format.h: the header holds
// its features at byte 24 and observations at byte 32).
ChunkStoreEntry EntryOf(const std::string& file, const std::string& bytes) {
  const auto features = static_cast<int64_t>(chunk_format::DecodeFixed64(bytes.data() + 24));
  const auto observations = static_cast<int64_t>(chunk_format::DecodeFixed64(bytes.data() + 32));
  return {file, features, observations, static_cast<int64_t>(bytes.size()),
          crc32c::Value(bytes)};
}

// Chunk files written to temporaries but not yet durable: made durable
// together (synced concurrently, renamed, the folder synced once), and
// removed if any step fails.
class PendingChunkGroup {
 public:
  PendingChunkGroup(Env* env, std::string chunk_dir)
      : env_(env), chunk_dir_(std::move(chunk_dir)) {}
  ~PendingChunkGroup() { RemoveTemporaries(env_, &group_); }

  size_t size() const { return group_.size(); }

  // Writes `bytes` to a temporary beside `path`. The file joins the group
  // before the error check, so that a failure removes it too.
  Status Add(const std::string& path, const std::string& bytes) {
    PendingFile pending;
    pending.path = path;
    pending.temporary = TemporaryFileName(path);
    Status status = [&]() -> Status {
      GS_ASSIGN_OR_RETURN(pending.file, env_->NewWritableFile(pending.temporary));
      return pending.file->Append(bytes);
    }();
    group_.push_back(std::move(pending));
    if (status.ok()) return Status::Ok();
    RemoveTemporaries(env_, &group_);
    return status.WithContext("writing " + path);
  }

  Status MakeDurable() {
    Status status = SyncAndCloseConcurrently(&group_, ChunkStoreWriter::kMaxSyncThreads);
    for (size_t i = 0; status.ok() && i < group_.size(); ++i) {
      status = env_->Rename(group_[i].temporary, group_[i].path);
      if (!status.ok()) status = status.WithContext("writing " + group_[i].path);
    }
    if (!status.ok()) {
      RemoveTemporaries(env_, &group_);
      return status;
    }
    group_.clear();
    return env_->SyncDirectory(chunk_dir_);
  }

 private:
  Env* const env_;
  const std::string chunk_dir_;
  std::vector<PendingFile> group_;
};

}  // namespace

ChunkStoreWriter::ChunkStoreWriter(Env* env, std::string dir, ChunkStoreWriteOptions options)
    : env_(env), dir_(std::move(dir)), options_(std::move(options)) {
  GS_CHECK(env_ != nullptr);
}

Status ChunkStoreWriter::Uncommit() {
  GS_RETURN_IF_ERROR(options_.Validate());
  // Never into a folder that is not ours: nothing below is deleted there.
  GS_RETURN_IF_ERROR(ClaimStoreDirectory(env_, dir_));
  const std::string chunk_dir = Join(dir_, kChunkStoreChunkDirectory);
  std::error_code error;
  std::filesystem::create_directories(chunk_dir, error);
  if (error) return Status::IOError(chunk_dir + ": mkdir: " + error.message());
  // Temporary files of a writer killed before its rename (TemporaryFileName:
  // "NAME.tmp-PID") are never renamed by anyone: remove them (also in work/
  // and scans/), so a resumed or restarted ingest leaves exactly the files of
  // an uninterrupted one. One writer per store at a time (the commands hold
  // its exclusive lock, storage/store_directory.h), so none is in use.
  GS_RETURN_IF_ERROR(RemoveStaleTemporaries(env_, dir_, /*recursive=*/true));
  // From here until the new manifest is durable the directory is an
  // incomplete store.
  const std::string manifest = Join(dir_, kChunkStoreManifestName);
  if (env_->FileExists(manifest)) {
    GS_RETURN_IF_ERROR(env_->RemoveFile(manifest));
    GS_RETURN_IF_ERROR(env_->SyncDirectory(dir_));
  }
  // A solver checkpoint of the old contents must not be resumed on the new
  // ones (`graphslam solve STORE --resume`).
  for (const char* suffix : {"", ".candidates.bin", ".ids.bin"}) {
    const std::string path = Join(dir_, std::string(kChunkStoreCheckpointName) + suffix);
    if (env_->FileExists(path)) GS_RETURN_IF_ERROR(env_->RemoveFile(path));
  }
  return Status::Ok();
}

Status ChunkStoreWriter::WriteProblem(const core::Problem2d& problem) {
  const std::string path = Join(dir_, kChunkStoreProblemName);
  if (problem.observations.empty()) return WriteNativeLog(problem, path, env_);
  core::Problem2d pose_only = problem;
  pose_only.observations.clear();
  pose_only.observations.shrink_to_fit();
  return WriteNativeLog(pose_only, path, env_);
}

Status ChunkStoreWriter::WriteChunks(const core::ChunkSource& chunks, int64_t first,
                                     const std::function<Status(int64_t)>& on_durable) {
  GS_CHECK(first >= 0 && static_cast<int64_t>(entries_.size()) == first);
  return WriteRange(chunks, first, chunks.NumChunks(), on_durable);
}

Status ChunkStoreWriter::WriteChunkShard(const core::ChunkSource& chunks, int64_t first,
                                         int64_t end) {
  GS_CHECK(first >= 0 && first <= end && end <= chunks.NumChunks());
  entries_.clear();
  return WriteRange(chunks, first, end, {});
}

void ChunkStoreWriter::SetEntries(std::vector<ChunkStoreEntry> entries,
                                  std::vector<ChunkStoreShard> shards) {
  entries_ = std::move(entries);
  shards_ = std::move(shards);
}

Status ChunkStoreWriter::WriteRange(const core::ChunkSource& chunks, int64_t first, int64_t end,
                                    const std::function<Status(int64_t)>& on_durable) {
  GS_RETURN_IF_ERROR(options_.Validate());
  const std::string chunk_dir = Join(dir_, kChunkStoreChunkDirectory);
  struct Item {
    int64_t index = 0;
    core::ObservationChunk chunk;
    std::string bytes;
    Status status;
  };
  Status failure;  // the first error, in chunk order (set by serial stages only)
  std::atomic<bool> failed{false};
  // Items go back from the last stage to the first: a chunk's observations
  // and bytes reuse the pages of an earlier one (fresh ones cost a fault and
  // a zero-fill each: ~1/4 of the ingest's page faults were these).
  internal::BlockPool<Item> pool;
  PendingChunkGroup group(env_, chunk_dir);
  int64_t next = first;
  // Stage 3, in chunk order: the file, its entry, and every
  // options_.sync_group_chunks files (and at the end) the group made durable.
  const auto store = [&](const Item& item) -> Status {
    GS_RETURN_IF_ERROR(item.status);
    const std::string file = ChunkStoreFileName(item.index);
    GS_RETURN_IF_ERROR(group.Add(Join(chunk_dir, file), item.bytes));
    entries_.push_back(EntryOf(file, item.bytes));
    if (static_cast<int64_t>(group.size()) < options_.sync_group_chunks && item.index + 1 != end)
      return Status::Ok();
    GS_RETURN_IF_ERROR(group.MakeDurable());
    return on_durable ? on_durable(static_cast<int64_t>(entries_.size())) : Status::Ok();
  };
  tbb::parallel_pipeline(
      kChunksInFlight,
      tbb::make_filter<void, Item*>(
          tbb::filter_mode::serial_in_order,
          [&](tbb::flow_control& control) -> Item* {
            if (next >= end || failed.load()) {
              control.stop();
              return nullptr;
            }
            std::unique_ptr<Item> item = pool.Take();
            item->index = next++;
            item->status = LoadChunkAt(chunks, item->index, &item->chunk);
            if (!item->status.ok()) failed = true;
            return item.release();
          }) &
          tbb::make_filter<Item*, Item*>(
              tbb::filter_mode::parallel,
              [&](Item* item) -> Item* {
                if (item->status.ok()) {
                  item->status =
                      EncodeObservationChunk(item->chunk, options_.chunk, &item->bytes)
                          .WithContext("writing " +
                                       Join(chunk_dir, ChunkStoreFileName(item->index)));
                }
                return item;
              }) &
          tbb::make_filter<Item*, void>(tbb::filter_mode::serial_in_order, [&](Item* raw) {
            std::unique_ptr<Item> item(raw);
            if (failure.ok()) {
              failure = store(*item);
              if (!failure.ok()) failed = true;
            }
            pool.Give(std::move(item));
          }));
  if (!failure.ok()) return failure;  // the group's temporaries go with it
  GS_CHECK(group.size() == 0);
  if (first == end) GS_RETURN_IF_ERROR(env_->SyncDirectory(chunk_dir));
  return Status::Ok();
}

Status ChunkStoreWriter::RecoverEntries(int64_t count) {
  entries_.clear();
  const std::string chunk_dir = Join(dir_, kChunkStoreChunkDirectory);
  for (int64_t k = 0; k < count; ++k) {
    const std::string file = ChunkStoreFileName(k);
    const std::string path = Join(chunk_dir, file);
    std::ifstream in(path, std::ios::binary);
    char header[chunk_format::kHeaderSize];
    if (!in || !in.read(header, sizeof(header)))
      return Status::Corruption(path + ": missing or shorter than a chunk header; expected a "
                                "durable chunk (the ingest progress says it was written)");
    const uint32_t stored = crc32c::Unmask(
        chunk_format::DecodeFixed32(header + chunk_format::kHeaderCrcOffset));
    const uint32_t actual = crc32c::Value(header, chunk_format::kHeaderCrcOffset);
    if (chunk_format::DecodeFixed64(header) != chunk_format::kMagic || stored != actual)
      return Status::Corruption(path + ": bad chunk header (magic or crc)");
    const auto index = static_cast<int64_t>(chunk_format::DecodeFixed64(header + 16));
    if (index != k)
      return Status::Corruption(path + ": header chunk index is " + std::to_string(index) +
                                "; expected " + std::to_string(k));
    GS_ASSIGN_OR_RETURN(FileChecksum sum, ChecksumFile(path));
    entries_.push_back({file, static_cast<int64_t>(chunk_format::DecodeFixed64(header + 24)),
                        static_cast<int64_t>(chunk_format::DecodeFixed64(header + 32)),
                        sum.bytes, sum.crc32c});
  }
  return Status::Ok();
}

Status ChunkStoreWriter::Commit() {
  nlohmann::json entries = nlohmann::json::array();
  int64_t total_features = 0, total_observations = 0, total_bytes = 0;
  for (const ChunkStoreEntry& entry : entries_) {
    entries.push_back({{"file", entry.file},
                       {"features", entry.features},
                       {"observations", entry.observations},
                       {"bytes", entry.bytes},
                       {"crc32c", FormatCrc32c(entry.crc32c)}});
    total_features += entry.features;
    total_observations += entry.observations;
    total_bytes += entry.bytes;
  }
  // Every other file of the store: the problem, then the scans (sorted).
  GS_ASSIGN_OR_RETURN(nlohmann::json files, ListStoreFiles(dir_));
  nlohmann::json manifest;
  manifest["format"] = kChunkStoreFormatName;
  manifest["version"] = kChunkStoreVersion;
  manifest["source"] = options_.source;
  if (options_.input.bytes >= 0) {
    manifest["input"] = {{"bytes", options_.input.bytes},
                         {"crc32c", FormatCrc32c(options_.input.crc32c)}};
  } else {
    manifest["input"] = nullptr;
  }
  manifest["files"] = std::move(files);
  manifest["problem"] = kChunkStoreProblemName;
  manifest["num_chunks"] = static_cast<int64_t>(entries_.size());
  manifest["total_features"] = total_features;
  manifest["total_observations"] = total_observations;
  manifest["total_bytes"] = total_bytes;
  manifest["chunks"] = std::move(entries);
  if (!shards_.empty()) {
    nlohmann::json shards = nlohmann::json::array();
    for (const ChunkStoreShard& shard : shards_)
      shards.push_back(
          {{"rank", shard.rank}, {"first_chunk", shard.first_chunk}, {"chunks", shard.chunks}});
    manifest["shards"] = std::move(shards);
  }
  SealJson(&manifest);
  GS_RETURN_IF_ERROR(
      WriteStringAtomically(env_, Join(dir_, kChunkStoreManifestName), manifest.dump(2) + "\n"));
  // Chunk files of an older, longer store: ours (our names, in a store of
  // ours), listed by no manifest any more; the store holds exactly its files.
  for (auto k = static_cast<int64_t>(entries_.size());; ++k) {
    const std::string path = Join(Join(dir_, kChunkStoreChunkDirectory), ChunkStoreFileName(k));
    if (!env_->FileExists(path)) break;
    GS_RETURN_IF_ERROR(env_->RemoveFile(path));
  }
  return Status::Ok();
}

}  // namespace graphslam::storage
