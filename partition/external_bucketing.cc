#include "partition/external_bucketing.h"

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <numeric>
#include <type_traits>
#include <utility>

namespace graphslam::partition {
namespace {

// Bucket files hold raw Observation structs: they are scratch of this process,
// read back by the same binary, never an interchange format. Observation is
// integers, an enum and fixed-size Eigen matrices (inline arrays of doubles,
// no pointers), so its bytes round-trip; Eigen's user-provided copy
// constructors are why std::is_trivially_copyable does not hold.
static_assert(std::is_trivially_destructible_v<core::Observation>);

struct FileCloser {
  void operator()(std::FILE* file) const {
    if (file != nullptr) std::fclose(file);
  }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

Status IoError(const std::string& path, const char* what) {
  return Status::IOError(path + ": " + what + ": " + std::strerror(errno));
}

}  // namespace

Status ExternalBucketingOptions::Validate() const {
  if (max_observations_per_chunk <= 0)
    return Status::InvalidArgument("max_observations_per_chunk must be > 0, got " +
                                   std::to_string(max_observations_per_chunk));
  if (buffer_observations < max_observations_per_chunk)
    return Status::InvalidArgument(
        "buffer_observations (" + std::to_string(buffer_observations) +
        ") must be >= max_observations_per_chunk (" +
        std::to_string(max_observations_per_chunk) + ")");
  if (work_dir.empty()) return Status::InvalidArgument("work_dir is empty");
  return Status::Ok();
}

void FeatureIndex::Resize(int32_t num_features) {
  if (num_features <= static_cast<int32_t>(counts_.size())) return;
  counts_.resize(num_features, 0);
  first_pose_.resize(num_features, std::numeric_limits<int32_t>::max());
}

void FeatureIndex::Add(const core::Observation& observation) {
  GS_CHECK(observation.feature >= 0 && observation.pose >= 0);
  if (observation.feature >= static_cast<int32_t>(counts_.size())) {
    // Geometric growth: amortized O(1) per new feature.
    Resize(std::max(observation.feature + 1, 2 * static_cast<int32_t>(counts_.size())));
  }
  GS_CHECK(counts_[observation.feature] < std::numeric_limits<int32_t>::max());
  ++counts_[observation.feature];
  first_pose_[observation.feature] = std::min(first_pose_[observation.feature], observation.pose);
  ++observations_;
}

int32_t InitializationObservations::Find(int32_t pose) {
  while (parent_[pose] != pose) {
    parent_[pose] = parent_[parent_[pose]];
    pose = parent_[pose];
  }
  return pose;
}

void InitializationObservations::Add(const core::Observation& observation) {
  GS_CHECK(observation.feature >= 0 && observation.pose >= 0);
  if (observation.pose >= static_cast<int32_t>(parent_.size())) {
    const size_t old = parent_.size();
    parent_.resize(std::max<size_t>(observation.pose + 1, 2 * old));
    std::iota(parent_.begin() + static_cast<std::ptrdiff_t>(old), parent_.end(),
              static_cast<int32_t>(old));
  }
  if (observation.feature >= static_cast<int32_t>(feature_anchor_.size()))
    feature_anchor_.resize(
        std::max<size_t>(observation.feature + 1, 2 * feature_anchor_.size()), -1);
  int32_t& anchor = feature_anchor_[observation.feature];
  if (anchor < 0) {
    anchor = observation.pose;  // first sight: places the feature
    kept_.push_back(observation);
    return;
  }
  const int32_t a = Find(anchor), b = Find(observation.pose);
  if (a == b) return;  // adds no connectivity
  parent_[a] = b;
  kept_.push_back(observation);
}

StatusOr<std::unique_ptr<BucketChunkSource>> BucketChunkSource::Build(
    const FeatureIndex& index, const ObservationReplay& replay,
    const ExternalBucketingOptions& options) {
  GS_RETURN_IF_ERROR(options.Validate());
  std::unique_ptr<BucketChunkSource> source(new BucketChunkSource());
  source->options_ = options;
  const std::vector<int32_t>& counts = index.counts();
  const std::vector<int32_t>& first_pose = index.first_pose();
  const int32_t num_features = static_cast<int32_t>(counts.size());

  // The plan of InMemoryChunkSource: observed features by first pose (stable),
  // greedy packing of whole features into at most B observations.
  std::vector<int32_t> order;
  for (int32_t f = 0; f < num_features; ++f)
    if (counts[f] > 0) order.push_back(f);
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return first_pose[a] < first_pose[b]; });
  source->feature_chunk_.assign(num_features, -1);
  const int64_t budget = options.max_observations_per_chunk;
  std::vector<int32_t> members;
  int64_t members_observations = 0;
  auto flush = [&]() {
    if (members.empty()) return;
    std::sort(members.begin(), members.end());
    const int32_t chunk = static_cast<int32_t>(source->chunk_features_.size());
    for (int32_t f : members) source->feature_chunk_[f] = chunk;
    source->chunk_features_.push_back(members);
    source->chunk_observations_.push_back(members_observations);
    members.clear();
    members_observations = 0;
  };
  for (int32_t f : order) {
    if (members_observations > 0 && members_observations + counts[f] > budget) flush();
    members.push_back(f);
    members_observations += counts[f];
  }
  flush();

  // Buckets: runs of consecutive chunks of at most K observations.
  const int64_t capacity = options.buffer_observations;
  for (size_t k = 0; k < source->chunk_observations_.size(); ++k) {
    const int64_t n = source->chunk_observations_[k];
    if (source->bucket_observations_.empty() ||
        (source->bucket_observations_.back() > 0 &&
         source->bucket_observations_.back() + n > capacity))
      source->bucket_observations_.push_back(0);
    source->bucket_observations_.back() += n;
    source->chunk_bucket_.push_back(static_cast<int64_t>(source->bucket_observations_.size()) - 1);
  }
  BucketingStats& stats = source->stats_;
  stats.chunks = source->NumChunks();
  stats.buckets = static_cast<int64_t>(source->bucket_observations_.size());

  // Pass 2: spill through a buffer of K observations.
  std::vector<core::Observation> buffer;
  buffer.reserve(static_cast<size_t>(std::min<int64_t>(capacity, index.observations())));
  std::vector<int64_t> seen(source->bucket_observations_.size(), 0);
  auto spill = [&]() -> Status {
    if (buffer.empty()) return Status::Ok();
    const auto bucket_of = [&](const core::Observation& o) {
      return source->chunk_bucket_[source->feature_chunk_[o.feature]];
    };
    std::stable_sort(buffer.begin(), buffer.end(),
                     [&](const core::Observation& a, const core::Observation& b) {
                       return bucket_of(a) < bucket_of(b);
                     });
    for (size_t begin = 0; begin < buffer.size();) {
      const int64_t bucket = bucket_of(buffer[begin]);
      size_t end = begin;
      while (end < buffer.size() && bucket_of(buffer[end]) == bucket) ++end;
      const std::string path = source->BucketPath(bucket);
      File file(std::fopen(path.c_str(), "ab"));
      if (!file) return IoError(path, "open for append");
      const size_t n = end - begin;
      if (std::fwrite(buffer.data() + begin, sizeof(core::Observation), n, file.get()) != n)
        return IoError(path, "write");
      if (std::fclose(file.release()) != 0) return IoError(path, "close");
      stats.spilled_bytes += static_cast<int64_t>(n * sizeof(core::Observation));
      seen[bucket] += static_cast<int64_t>(n);
      begin = end;
    }
    ++stats.spills;
    buffer.clear();
    return Status::Ok();
  };
  GS_RETURN_IF_ERROR(replay([&](const core::Observation& observation) -> Status {
    if (observation.feature < 0 || observation.feature >= num_features ||
        source->feature_chunk_[observation.feature] < 0)
      return Status::Corruption("observation of feature " + std::to_string(observation.feature) +
                                " in the second pass was not seen in the first; expected the "
                                "same input twice");
    buffer.push_back(observation);
    ++stats.observations;
    stats.peak_observations_in_memory =
        std::max(stats.peak_observations_in_memory, static_cast<int64_t>(buffer.size()));
    if (static_cast<int64_t>(buffer.size()) >= capacity) return spill();
    return Status::Ok();
  }));
  GS_RETURN_IF_ERROR(spill());
  buffer.shrink_to_fit();
  for (size_t b = 0; b < seen.size(); ++b)
    if (seen[b] != source->bucket_observations_[b])
      return Status::Corruption(source->BucketPath(static_cast<int64_t>(b)) + ": " +
                                std::to_string(seen[b]) + " observations spilled; the first "
                                "pass counted " + std::to_string(source->bucket_observations_[b]));
  return source;
}

std::string BucketChunkSource::BucketPath(int64_t bucket) const {
  char name[40];
  std::snprintf(name, sizeof(name), "bucket_%06" PRId64 ".bin", bucket);
  return (std::filesystem::path(options_.work_dir) / name).string();
}

Status BucketChunkSource::LoadBucket(int64_t bucket) const {
  const std::string path = BucketPath(bucket);
  const int64_t n = bucket_observations_[bucket];
  bucket_.clear();
  bucket_.shrink_to_fit();  // the previous bucket's memory goes before the next one's
  bucket_.resize(static_cast<size_t>(n));
  File file(std::fopen(path.c_str(), "rb"));
  if (!file) return IoError(path, "open for reading");
  if (std::fread(bucket_.data(), sizeof(core::Observation), static_cast<size_t>(n), file.get()) !=
      static_cast<size_t>(n))
    return Status::Corruption(path + ": shorter than the " + std::to_string(n) +
                              " observations spilled into it");
  // Grouped by (chunk, feature); stable, so each feature keeps its input order.
  std::stable_sort(bucket_.begin(), bucket_.end(),
                   [&](const core::Observation& a, const core::Observation& b) {
                     const int32_t ca = feature_chunk_[a.feature], cb = feature_chunk_[b.feature];
                     return ca != cb ? ca < cb : a.feature < b.feature;
                   });
  loaded_bucket_ = bucket;
  bucket_cursor_ = 0;
  // The spill file is not needed once read (frees disk as the store grows).
  std::error_code error;
  std::filesystem::remove(path, error);
  return Status::Ok();
}

Status BucketChunkSource::Load(int64_t index, core::ObservationChunk* chunk) const {
  GS_CHECK(chunk != nullptr);
  if (index < 0 || index >= NumChunks())
    return Status::InvalidArgument("chunk " + std::to_string(index) + " out of range; expected 0.." +
                                   std::to_string(NumChunks() - 1));
  const int64_t bucket = chunk_bucket_[index];
  if (bucket != loaded_bucket_) {
    if (bucket < loaded_bucket_)
      return Status::InvalidArgument("BucketChunkSource::Load is sequential: chunk " +
                                     std::to_string(index) + " lies in bucket " +
                                     std::to_string(bucket) + ", before the loaded bucket " +
                                     std::to_string(loaded_bucket_));
    GS_RETURN_IF_ERROR(LoadBucket(bucket));
  }
  const size_t n = static_cast<size_t>(chunk_observations_[index]);
  // Chunks of a bucket are loaded in order: chunk `index` is the next run.
  GS_CHECK(bucket_cursor_ + n <= bucket_.size());
  GS_CHECK(feature_chunk_[bucket_[bucket_cursor_].feature] == index);
  chunk->Clear();
  chunk->index = index;
  chunk->features = chunk_features_[index];
  chunk->observations.assign(bucket_.begin() + static_cast<std::ptrdiff_t>(bucket_cursor_),
                             bucket_.begin() + static_cast<std::ptrdiff_t>(bucket_cursor_ + n));
  chunk->feature_begin.reserve(chunk->features.size() + 1);
  for (size_t i = 0; i < chunk->observations.size(); ++i)
    if (i == 0 || chunk->observations[i].feature != chunk->observations[i - 1].feature)
      chunk->feature_begin.push_back(static_cast<int64_t>(i));
  chunk->feature_begin.push_back(static_cast<int64_t>(chunk->observations.size()));
  GS_CHECK(chunk->feature_begin.size() == chunk->features.size() + 1);
  bucket_cursor_ += n;
  stats_.peak_observations_in_memory = std::max(
      stats_.peak_observations_in_memory, static_cast<int64_t>(bucket_.size() + n));
  return Status::Ok();
}

}  // namespace graphslam::partition
