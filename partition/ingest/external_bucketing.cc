#include "partition/ingest/external_bucketing.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <thread>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <numeric>
#include <string_view>
#include <type_traits>
#include <utility>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_pipeline.h>

#include "core/chunk_feature_runs.h"
#include "partition/ingest/spill_frames.h"
#include "storage/env.h"
#include "storage/internal/text_blocks.h"
#include "storage/stop_point.h"

namespace graphslam::partition {

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

void FeatureIndex::Reserve(int64_t num_features) {
  if (num_features <= 0 || num_features > std::numeric_limits<int32_t>::max()) return;
  counts_.reserve(static_cast<size_t>(num_features));
  first_pose_.reserve(static_cast<size_t>(num_features));
}

void FeatureIndex::Add(const core::Observation& observation) {
  GS_CHECK(observation.feature >= 0 && observation.pose >= 0);
  if (observation.feature >= static_cast<int32_t>(counts_.size())) {
    // Grown to exactly the features seen: std::vector's own growth is
    // geometric (amortized O(1)) and leaves the spare capacity untouched, so
    // not resident; doubling the size here wrote (made resident) ~1.5x the
    // 8 B per feature.
    Resize(observation.feature + 1);
  }
  GS_CHECK(counts_[observation.feature] < std::numeric_limits<int32_t>::max());
  ++counts_[observation.feature];
  first_pose_[observation.feature] = std::min(first_pose_[observation.feature], observation.pose);
  ++observations_;
}

StatusOr<std::unique_ptr<BucketChunkSource>> BucketChunkSource::Plan(
    const FeatureIndex& index, const ExternalBucketingOptions& options) {
  GS_RETURN_IF_ERROR(options.Validate());
  std::unique_ptr<BucketChunkSource> source(new BucketChunkSource());
  source->options_ = options;
  const std::vector<int32_t>& counts = index.counts();
  const std::vector<int32_t>& first_pose = index.first_pose();
  const int32_t num_features = static_cast<int32_t>(counts.size());

  // The plan of InMemoryChunkSource: observed features by first pose (stable),
  // greedy packing of whole features into at most B observations.
  std::vector<int32_t> order;
  order.reserve(counts.size());  // never grown by copying; unused capacity is not resident
  for (int32_t f = 0; f < num_features; ++f)
    if (counts[f] > 0) order.push_back(f);
  std::stable_sort(order.begin(), order.end(),
                   [&](int32_t a, int32_t b) { return first_pose[a] < first_pose[b]; });
  source->feature_chunk_.assign(num_features, -1);
  source->feature_slot_.assign(num_features, -1);
  const int64_t budget = options.max_observations_per_chunk;
  std::vector<int32_t> members;
  int64_t members_observations = 0;
  auto flush = [&]() {
    if (members.empty()) return;
    std::sort(members.begin(), members.end());
    const int32_t chunk = static_cast<int32_t>(source->chunk_features_.size());
    for (size_t i = 0; i < members.size(); ++i) {
      source->feature_chunk_[members[i]] = chunk;
      source->feature_slot_[members[i]] = static_cast<int32_t>(i);
    }
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
  int64_t slot_in_bucket = 0;
  for (size_t k = 0; k < source->chunk_observations_.size(); ++k) {
    const int64_t n = source->chunk_observations_[k];
    if (source->bucket_observations_.empty() ||
        (source->bucket_observations_.back() > 0 &&
         source->bucket_observations_.back() + n > capacity)) {
      source->bucket_observations_.push_back(0);
      source->bucket_first_chunk_.push_back(static_cast<int64_t>(k));
      slot_in_bucket = 0;
    }
    source->chunk_offset_.push_back(source->bucket_observations_.back());
    source->chunk_slot_.push_back(slot_in_bucket);
    slot_in_bucket += static_cast<int64_t>(source->chunk_features_[k].size());
    source->bucket_observations_.back() += n;
    source->chunk_bucket_.push_back(static_cast<int64_t>(source->bucket_observations_.size()) - 1);
  }
  source->stats_.chunks = source->NumChunks();
  source->stats_.buckets = source->NumBuckets();
  return source;
}

namespace {

// fsyncs `paths` concurrently (the file system folds the journal commits).
Status SyncPaths(const std::vector<std::string>& paths) {
  std::vector<Status> statuses(paths.size());
  std::atomic<size_t> next{0};
  auto work = [&]() {
    for (size_t i = next++; i < paths.size(); i = next++)
      statuses[i] = storage::Env::Default()->SyncFile(paths[i]);
  };
  std::vector<std::thread> pool;
  for (size_t t = 1; t < std::min<size_t>(paths.size(), 16); ++t) pool.emplace_back(work);
  work();
  for (std::thread& thread : pool) thread.join();
  for (const Status& status : statuses) GS_RETURN_IF_ERROR(status);
  return Status::Ok();
}

// Back to the last checkpoint: what a killed run appended after it goes.
// The progress counts observations; the frame headers say where they end.
Status TruncateToProgress(const std::vector<std::string>& bucket_paths,
                          const SpillProgress& progress) {
  for (size_t b = 0; b < bucket_paths.size(); ++b) {
    const std::string& path = bucket_paths[b];
    const bool exists = storage::Env::Default()->FileExists(path);
    if (!exists && progress.bucket_observations[b] == 0) continue;
    if (!exists)
      return Status::Corruption(path + ": missing; the spill progress records " +
                                std::to_string(progress.bucket_observations[b]) +
                                " observations in it");
    GS_ASSIGN_OR_RETURN(const int64_t keep,
                        SpillFrameBoundary(path, progress.bucket_observations[b]));
    GS_RETURN_IF_ERROR(
        storage::Env::Default()->TruncateFile(path, static_cast<uint64_t>(keep)));
  }
  return Status::Ok();
}

// Frames of a spill between its encoders and its files at once.
constexpr size_t kSpillFramesInFlight = 8;

// Appends buffered observations to the bucket files: sorted by bucket
// (stable, so each run keeps input order), each bucket's run as frames of at
// most kMaxSpillFrameObservations, compressed in parallel, appended in order.
//
// The sort runs in the caller's thread; the encoding and the appends of the
// sorted copy run in a background job while the caller refills the buffer
// (the replay's decoding and the spill's writes overlap). One job at a time:
// the next Spill waits for the previous job before it sorts into the same
// scratch, so the files get the spills in order, and memory stays the
// buffer + the sorted copy + kSpillFramesInFlight frames (when the spill
// was synchronous: every frame of a spill). What the job updates (the
// progress, the spill stats, the touched files) is read only after Wait.
class BucketWriter {
 public:
  using BucketOf = std::function<int64_t(const core::Observation&)>;

  BucketWriter(const std::vector<std::string>& paths, BucketOf bucket_of, int zstd_level,
               BucketingStats* stats, SpillProgress* progress)
      : paths_(paths), bucket_of_(std::move(bucket_of)),
        encoders_([zstd_level] { return zstd_level; }), stats_(*stats), progress_(*progress),
        run_(paths.size() + 1, 0), touched_(paths.size(), 0) {}
  ~BucketWriter() { static_cast<void>(Wait()); }  // an error was reported or is moot
  BucketWriter(const BucketWriter&) = delete;
  BucketWriter& operator=(const BucketWriter&) = delete;

  // Sorts and empties *buffer, then encodes and appends the sorted copy in
  // the background. Returns the previous job's error, if any.
  Status Spill(std::vector<core::Observation>* buffer) {
    if (buffer->empty()) return Status::Ok();
    GS_RETURN_IF_ERROR(Wait());  // scratch_ is free again
    SortByBucket(*buffer);
    const auto observations = static_cast<int64_t>(buffer->size());
    buffer->clear();
    job_ = std::thread([this, observations] { job_status_ = EncodeAndAppend(observations); });
    return Status::Ok();
  }

  // Waits for the background job; its error, if any.
  Status Wait() {
    if (job_.joinable()) job_.join();
    Status status = std::move(job_status_);
    job_status_ = Status::Ok();
    return status;
  }

  // The bucket files appended to since the last call.
  std::vector<std::string> TakeTouched() {
    std::vector<std::string> paths;
    for (size_t b = 0; b < paths_.size(); ++b)
      if (touched_[b]) paths.push_back(paths_[b]);
    std::fill(touched_.begin(), touched_.end(), 0);
    return paths;
  }

  // Frees the compressors and hands over the sort's scratch (after Wait;
  // the few frames go with the writer).
  std::vector<core::Observation> Release() {
    encoders_.clear();
    return std::move(scratch_);
  }

 private:
  struct Piece {
    int64_t bucket;
    int64_t begin, end;  // in scratch_
  };

  // A piece's frame on its way from the encoder to its file.
  struct Frame {
    size_t piece = 0;
    std::vector<char> bytes;  // kept from piece to piece: no fresh pages per frame
    Status status;
  };

  // The background job: scratch_'s runs as frames, appended to their files
  // in a bounded pipeline -- pieces in order (serial), encoded (parallel, an
  // encoder per thread), appended in order (serial; a bucket's file is open
  // while its pieces arrive) -- so the writes overlap the encoding and at
  // most kSpillFramesInFlight frames are held, their buffers reused.
  Status EncodeAndAppend(int64_t observations) {
    const std::vector<Piece> pieces = Pieces();
    size_t next = 0;                  // first stage only
    Status failure;                   // last stage only
    std::atomic<bool> failed{false};  // read by the first stage
    std::unique_ptr<storage::WritableFile> file;  // last stage only
    int64_t open_bucket = -1;
    // Closes the open bucket's file; its run is then counted as spilled.
    const auto close = [&]() -> Status {
      if (open_bucket < 0) return Status::Ok();
      const int64_t b = open_bucket;
      open_bucket = -1;
      GS_RETURN_IF_ERROR(file->Close());
      file.reset();
      const int64_t n = run_[b + 1] - run_[b];
      stats_.spilled_raw_bytes += n * static_cast<int64_t>(sizeof(core::Observation));
      progress_.bucket_observations[b] += n;
      touched_[b] = 1;
      return Status::Ok();
    };
    const auto append = [&](const Frame& frame) -> Status {
      GS_RETURN_IF_ERROR(frame.status);
      const int64_t b = pieces[frame.piece].bucket;
      if (b != open_bucket) {
        GS_RETURN_IF_ERROR(close());
        GS_ASSIGN_OR_RETURN(file, storage::Env::Default()->NewAppendableFile(paths_[b]));
        open_bucket = b;
      }
      GS_RETURN_IF_ERROR(file->Append(std::string_view(frame.bytes.data(), frame.bytes.size())));
      stats_.spilled_bytes += static_cast<int64_t>(frame.bytes.size());
      return Status::Ok();
    };
    tbb::parallel_pipeline(
        kSpillFramesInFlight,
        tbb::make_filter<void, Frame*>(
            tbb::filter_mode::serial_in_order,
            [&](tbb::flow_control& control) -> Frame* {
              if (next >= pieces.size() || failed) {
                control.stop();
                return nullptr;
              }
              std::unique_ptr<Frame> frame = frames_.Take();
              frame->piece = next++;
              return frame.release();
            }) &
            tbb::make_filter<Frame*, Frame*>(
                tbb::filter_mode::parallel,
                [&](Frame* frame) -> Frame* {
                  const Piece& piece = pieces[frame->piece];
                  frame->status = encoders_.local().Encode(
                      scratch_.data() + piece.begin, static_cast<size_t>(piece.end - piece.begin),
                      &frame->bytes);
                  return frame;
                }) &
            tbb::make_filter<Frame*, void>(tbb::filter_mode::serial_in_order, [&](Frame* raw) {
              std::unique_ptr<Frame> frame(raw);
              if (failure.ok()) {
                failure = append(*frame);
                if (!failure.ok()) failed = true;
              }
              frames_.Give(std::move(frame));
            }));
    if (failure.ok()) failure = close();
    file.reset();  // after an error: the rest of this spill is scratch past the checkpoint
    GS_RETURN_IF_ERROR(failure);
    progress_.observations += observations;
    ++stats_.spills;
    storage::StopPointAtCountForTests("ingest_spill", stats_.spills);
    return Status::Ok();
  }

  // Counting sort of `buffer` by bucket into scratch_; run_[b] .. run_[b + 1]
  // is bucket b's run.
  void SortByBucket(const std::vector<core::Observation>& buffer) {
    std::fill(run_.begin(), run_.end(), 0);
    for (const core::Observation& o : buffer) ++run_[static_cast<size_t>(bucket_of_(o)) + 1];
    for (size_t b = 1; b < run_.size(); ++b) run_[b] += run_[b - 1];
    // Room for a full buffer at once (it becomes the bucket loads' sorted
    // array, bucket_, when the spill is over).
    if (scratch_.capacity() < buffer.capacity()) {
      scratch_ = std::vector<core::Observation>();
      scratch_.reserve(buffer.capacity());
    }
    scratch_.resize(buffer.size());
    std::vector<int64_t> next(run_.begin(), run_.end() - 1);
    for (const core::Observation& o : buffer) scratch_[next[bucket_of_(o)]++] = o;
  }

  std::vector<Piece> Pieces() const {
    constexpr auto kMax = static_cast<int64_t>(kMaxSpillFrameObservations);
    std::vector<Piece> pieces;
    for (int64_t b = 0; b + 1 < static_cast<int64_t>(run_.size()); ++b)
      for (int64_t i = run_[b]; i < run_[b + 1]; i += kMax)
        pieces.push_back({b, i, std::min(run_[b + 1], i + kMax)});
    return pieces;
  }

  const std::vector<std::string>& paths_;
  const BucketOf bucket_of_;
  tbb::enumerable_thread_specific<SpillFrameEncoder> encoders_;
  BucketingStats& stats_;
  SpillProgress& progress_;
  std::vector<core::Observation> scratch_;
  std::vector<int64_t> run_;
  std::vector<char> touched_;
  storage::internal::BlockPool<Frame> frames_;
  std::thread job_;
  Status job_status_;  // the job's result, read after the join
};

// Corruption unless every observation of `block` is of a feature pass 1 saw.
Status CheckSeenInPassOne(const ObservationBlock& block,
                          const std::vector<int32_t>& feature_chunk) {
  const auto num_features = static_cast<int32_t>(feature_chunk.size());
  for (size_t i = 0; i < block.size; ++i) {
    const core::Observation& observation = block.observations[i];
    if (observation.feature < 0 || observation.feature >= num_features ||
        feature_chunk[observation.feature] < 0)
      return Status::Corruption("observation of feature " + std::to_string(observation.feature) +
                                " in the second pass was not seen in the first; expected the "
                                "same input twice");
  }
  return Status::Ok();
}

}  // namespace

Status BucketChunkSource::Spill(const ObservationBlockReplay& replay, SpillProgress* progress,
                                const SpillCheckpoint& checkpoint, double checkpoint_seconds) {
  GS_CHECK(progress != nullptr);
  const int64_t num_buckets = NumBuckets();
  BucketingStats& stats = stats_;
  if (progress->bucket_observations.empty())
    progress->bucket_observations.assign(static_cast<size_t>(num_buckets), 0);
  if (static_cast<int64_t>(progress->bucket_observations.size()) != num_buckets)
    return Status::Corruption("spill progress lists " +
                              std::to_string(progress->bucket_observations.size()) +
                              " buckets; the plan has " + std::to_string(num_buckets));
  std::vector<std::string> paths(static_cast<size_t>(num_buckets));
  for (int64_t b = 0; b < num_buckets; ++b) paths[b] = BucketPath(b);
  GS_RETURN_IF_ERROR(TruncateToProgress(paths, *progress));
  stats.observations = progress->observations;

  const int64_t capacity = options_.buffer_observations;
  std::vector<core::Observation> buffer;
  buffer.reserve(static_cast<size_t>(capacity));
  const auto bucket_of = [this](const core::Observation& o) {
    return chunk_bucket_[feature_chunk_[o.feature]];
  };
  const int64_t first_bucket = spill_first_bucket_;
  const int64_t end_bucket = spill_end_bucket_ < 0 ? num_buckets : spill_end_bucket_;
  const auto spilled_here = [&](int64_t b) { return b >= first_bucket && b < end_bucket; };
  BucketWriter writer(paths, bucket_of, options_.spill_zstd_level, &stats, progress);
  auto last_checkpoint = std::chrono::steady_clock::now();
  // Makes the touched bucket files durable, then reports *progress.
  auto take_checkpoint = [&]() -> Status {
    GS_RETURN_IF_ERROR(SyncPaths(writer.TakeTouched()));
    last_checkpoint = std::chrono::steady_clock::now();
    return checkpoint ? checkpoint(*progress) : Status::Ok();
  };
  int64_t resumable_offset = progress->replay_position;
  GS_RETURN_IF_ERROR(replay([&](const ObservationBlock& block) -> Status {
    GS_RETURN_IF_ERROR(CheckSeenInPassOne(block, feature_chunk_));
    // A block that does not fit is preceded by a spill at the block boundary:
    // the resumable point where the previous block ended.
    if (!buffer.empty() && static_cast<int64_t>(buffer.size() + block.size) > capacity) {
      GS_RETURN_IF_ERROR(writer.Spill(&buffer));
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() -
                                                           last_checkpoint).count();
      if (checkpoint && resumable_offset >= 0 && elapsed >= checkpoint_seconds) {
        GS_RETURN_IF_ERROR(writer.Wait());  // the spill is in the files
        progress->replay_position = resumable_offset;
        GS_RETURN_IF_ERROR(take_checkpoint());
      }
    }
    for (size_t i = 0; i < block.size; ++i) {
      // Spilled when full and more is to come, not as soon as full: a buffer
      // that fills up exactly at a block's end is spilled at the next block,
      // at a resumable point (blocks that divide the buffer would otherwise
      // never give one).
      if (!spilled_here(bucket_of(block.observations[i]))) continue;
      if (static_cast<int64_t>(buffer.size()) >= capacity)
        GS_RETURN_IF_ERROR(writer.Spill(&buffer));
      buffer.push_back(block.observations[i]);
      stats.peak_observations_in_memory =
          std::max(stats.peak_observations_in_memory, static_cast<int64_t>(buffer.size()));
    }
    stats.observations += static_cast<int64_t>(block.size);
    resumable_offset = block.end_offset;
    return Status::Ok();
  }));
  GS_RETURN_IF_ERROR(writer.Spill(&buffer));
  GS_RETURN_IF_ERROR(writer.Wait());
  // The buffer and the sort's scratch (<= K observations each) become the
  // bucket loads' decoded and sorted arrays (<= K each): their pages are
  // resident already, where fresh ones cost a fault and a zero-fill each.
  buffer.clear();
  read_ = std::move(buffer);
  bucket_ = writer.Release();
  loaded_bucket_ = -1;
  for (int64_t b = first_bucket; b < end_bucket; ++b)
    if (progress->bucket_observations[b] != bucket_observations_[b])
      return Status::Corruption(paths[b] + ": " +
                                std::to_string(progress->bucket_observations[b]) +
                                " observations spilled; the first pass counted " +
                                std::to_string(bucket_observations_[b]));
  progress->replay_position = resumable_offset;
  // Durable before the caller records that pass 2 is over.
  return SyncPaths(writer.TakeTouched());
}

void BucketChunkSource::RestrictSpillToChunks(int64_t first, int64_t end) {
  GS_CHECK(first >= 0 && first <= end && end <= NumChunks());
  if (first == end) {
    spill_first_bucket_ = spill_end_bucket_ = 0;
    return;
  }
  spill_first_bucket_ = chunk_bucket_[static_cast<size_t>(first)];
  spill_end_bucket_ = chunk_bucket_[static_cast<size_t>(end - 1)] + 1;
}

ObservationBlockReplay InBlocks(const ObservationReplay& replay) {
  return [&replay](const ObservationBlockSink& sink) -> Status {
    std::vector<core::Observation> block;
    auto deliver = [&]() -> Status {
      if (block.empty()) return Status::Ok();
      ObservationBlock view;
      view.observations = block.data();
      view.size = block.size();
      Status status = sink(view);
      block.clear();
      return status;
    };
    GS_RETURN_IF_ERROR(replay([&](const core::Observation& observation) -> Status {
      block.push_back(observation);
      return block.size() >= 4096 ? deliver() : Status::Ok();
    }));
    return deliver();
  };
}

StatusOr<std::unique_ptr<BucketChunkSource>> BucketChunkSource::Build(
    const FeatureIndex& index, const ObservationReplay& replay,
    const ExternalBucketingOptions& options) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<BucketChunkSource> source, Plan(index, options));
  SpillProgress progress;
  GS_RETURN_IF_ERROR(source->Spill(InBlocks(replay), &progress, nullptr, 0.0));
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
  // The whole file (~19 B per observation) into raw_, its frames found from
  // the headers and decoded in parallel (a decoder per thread) into read_,
  // then sorted into bucket_. All three keep their pages from bucket to
  // bucket: fresh pages cost a fault and zeroing each, and a fresh read_ per
  // bucket zeroed 72 B per observation of the input. The peak (inside this
  // call) is the same raw_ + read_ + bucket_ as when raw_ and read_ were
  // freed after each load; between loads they stay resident.
  const bool grows =
      bucket_.capacity() < static_cast<size_t>(n) || read_.capacity() < static_cast<size_t>(n);
  if (grows) {
    // Would be reallocated below while the others live: freed first instead,
    // and made room for the largest bucket of the range at once (reserved
    // pages are resident only once written), so that they grow once, not at
    // every bucket larger than those before.
    const int64_t end = spill_end_bucket_ < 0 ? NumBuckets() : spill_end_bucket_;
    int64_t largest = n;
    for (int64_t b = spill_first_bucket_; b < end; ++b)
      largest = std::max(largest, bucket_observations_[b]);
    for (std::vector<core::Observation>* array : {&bucket_, &read_}) {
      if (array->capacity() >= static_cast<size_t>(n)) continue;
      *array = std::vector<core::Observation>();
      array->reserve(static_cast<size_t>(largest));
    }
  }
  std::vector<char>& raw = raw_;
  {
    GS_ASSIGN_OR_RETURN(std::unique_ptr<storage::ReadableFile> file,
                        storage::Env::Default()->NewReadableFile(path));
    GS_ASSIGN_OR_RETURN(const uint64_t size, file->Size());
    if (raw.capacity() < size) raw = std::vector<char>();  // not copied when it grows
    raw.resize(static_cast<size_t>(size));
    GS_ASSIGN_OR_RETURN(const size_t got, file->Read(raw.size(), raw.data()));
    if (got != raw.size())
      return Status::IOError(path + ": read " + std::to_string(got) + " of " +
                             std::to_string(raw.size()) + " bytes");
  }
  GS_ASSIGN_OR_RETURN(const SpillFrameIndex frames,
                      IndexSpillFrames(path, raw.data(), raw.size()));
  if (frames.observations != n)
    return Status::Corruption(path + ": " + std::to_string(frames.observations) +
                              " observations in its frames; " + std::to_string(n) +
                              " were spilled into it");
  std::vector<core::Observation>& read = read_;
  read.resize(static_cast<size_t>(n));
  std::vector<Status> statuses(frames.offsets.size());
  tbb::enumerable_thread_specific<SpillFrameDecoder> decoders;
  tbb::parallel_for(size_t{0}, frames.offsets.size(), [&](size_t f) {
    const char* frame = raw.data() + frames.offsets[f];
    statuses[f] = decoders.local().DecodeFrame(path, static_cast<int64_t>(frames.offsets[f]),
                                               frame, FrameBytes(frame),
                                               read.data() + frames.firsts[f]);
  });
  for (const Status& status : statuses) GS_RETURN_IF_ERROR(status);
  // No load after the last bucket: its bytes go before the sorted copy is
  // made, as the only bucket of a small input's did when they never stayed.
  // Nor while bucket_ grows: raw_ is never resident with a new, larger
  // bucket_ (the peak stays raw + decoded + sorted of a bucket that fits).
  const int64_t end_bucket = spill_end_bucket_ < 0 ? NumBuckets() : spill_end_bucket_;
  if (grows || bucket + 1 >= end_bucket) raw = std::vector<char>();
  GS_RETURN_IF_ERROR(GroupByChunkAndFeature(path, bucket));
  loaded_bucket_ = bucket;
  return Status::Ok();
}

// read_ grouped by (chunk, feature) into bucket_: the order of one stable
// counting sort by feature slot within the bucket, done as two stable ones
// that run in parallel. First by chunk: the decoded observations are cut
// into ranges, each range counts its observations per chunk (in parallel),
// the counts give every (range, chunk) its place -- chunk k's run starts at
// chunk_offset_[k], ranges in input order -- and the ranges scatter (in
// parallel). Then each chunk's run by feature slot (chunks in parallel).
// Both sorts keep input order among equal keys, so each feature keeps its
// observations' input order and the result is the single sort's, whatever
// the threads.
Status BucketChunkSource::GroupByChunkAndFeature(const std::string& path, int64_t bucket) const {
  const std::vector<core::Observation>& read = read_;
  const auto n = static_cast<int64_t>(read.size());
  const int64_t first_chunk = bucket_first_chunk_[bucket];
  const int64_t last_chunk =
      bucket + 1 < NumBuckets() ? bucket_first_chunk_[bucket + 1] : NumChunks();
  const int64_t num_chunks = last_chunk - first_chunk;
  // Few ranges (the counts are ranges x chunks), enough for the threads.
  constexpr int64_t kMaxRanges = 16;
  constexpr int64_t kLeastRange = 16384;
  const int64_t ranges = std::clamp<int64_t>((n + kLeastRange - 1) / kLeastRange, 1, kMaxRanges);
  const auto range_begin = [&](int64_t r) { return n * r / ranges; };
  // place[r * num_chunks + c]: range r's count of chunk first_chunk + c, then
  // where its next observation of that chunk goes.
  std::vector<int64_t> place(static_cast<size_t>(ranges * num_chunks), 0);
  std::vector<Status> statuses(static_cast<size_t>(ranges));
  tbb::parallel_for(int64_t{0}, ranges, [&](int64_t r) {
    int64_t* count = place.data() + r * num_chunks;
    for (int64_t i = range_begin(r); i < range_begin(r + 1); ++i) {
      const core::Observation& o = read[static_cast<size_t>(i)];
      const int32_t chunk = feature_chunk_[o.feature];
      if (chunk < first_chunk || chunk >= last_chunk) {
        statuses[static_cast<size_t>(r)] = Status::Corruption(
            path + ": an observation of feature " + std::to_string(o.feature) + " (chunk " +
            std::to_string(chunk) + ") in bucket " + std::to_string(bucket) +
            "; expected chunks " + std::to_string(first_chunk) + ".." +
            std::to_string(last_chunk - 1));
        return;
      }
      ++count[chunk - first_chunk];
    }
  });
  for (const Status& status : statuses) GS_RETURN_IF_ERROR(status);
  for (int64_t c = 0; c < num_chunks; ++c) {
    const int64_t k = first_chunk + c;
    int64_t next = chunk_offset_[k];
    for (int64_t r = 0; r < ranges; ++r) {
      int64_t& slot = place[static_cast<size_t>(r * num_chunks + c)];
      const int64_t count = slot;
      slot = next;
      next += count;
    }
    if (next != chunk_offset_[k] + chunk_observations_[k])
      return Status::Corruption(path + ": chunk " + std::to_string(k) + " has " +
                                std::to_string(next - chunk_offset_[k]) +
                                " observations in bucket " + std::to_string(bucket) +
                                "; the first pass counted " +
                                std::to_string(chunk_observations_[k]));
  }
  bucket_.resize(static_cast<size_t>(n));
  tbb::parallel_for(int64_t{0}, ranges, [&](int64_t r) {
    int64_t* next = place.data() + r * num_chunks;
    for (int64_t i = range_begin(r); i < range_begin(r + 1); ++i) {
      const core::Observation& o = read[static_cast<size_t>(i)];
      bucket_[static_cast<size_t>(next[feature_chunk_[o.feature] - first_chunk]++)] = o;
    }
  });
  // Within each chunk by feature slot (a copy of the run, scattered back).
  tbb::enumerable_thread_specific<std::vector<core::Observation>> runs;
  tbb::parallel_for(first_chunk, last_chunk, [&](int64_t k) {
    const auto begin = static_cast<size_t>(chunk_offset_[k]);
    const auto size = static_cast<size_t>(chunk_observations_[k]);
    std::vector<core::Observation>& run = runs.local();
    run.assign(bucket_.begin() + static_cast<std::ptrdiff_t>(begin),
               bucket_.begin() + static_cast<std::ptrdiff_t>(begin + size));
    std::vector<size_t> next(chunk_features_[k].size() + 1, 0);
    for (const core::Observation& o : run) ++next[static_cast<size_t>(feature_slot_[o.feature]) + 1];
    for (size_t s = 1; s < next.size(); ++s) next[s] += next[s - 1];
    for (const core::Observation& o : run)
      bucket_[begin + next[static_cast<size_t>(feature_slot_[o.feature])]++] = o;
  });
  return Status::Ok();
}

void BucketChunkSource::ReleaseBucketsBefore(int64_t chunk) {
  while (released_buckets_ < NumBuckets()) {
    const int64_t end = released_buckets_ + 1 < NumBuckets()
                            ? bucket_first_chunk_[released_buckets_ + 1]
                            : NumChunks();
    if (end > chunk) break;
    // scratch: a leftover is harmless
    static_cast<void>(storage::Env::Default()->RemoveFile(BucketPath(released_buckets_)));
    ++released_buckets_;
  }
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
  const auto begin = static_cast<size_t>(chunk_offset_[index]);
  GS_CHECK(begin + n <= bucket_.size());
  GS_CHECK(feature_chunk_[bucket_[begin].feature] == index);
  chunk->Clear();
  chunk->index = index;
  chunk->observations.assign(bucket_.begin() + static_cast<std::ptrdiff_t>(begin),
                             bucket_.begin() + static_cast<std::ptrdiff_t>(begin + n));
  // LoadBucket ordered the chunk's observations by its feature slots.
  core::IndexFeatureRuns(chunk);
  GS_CHECK(chunk->features == chunk_features_[index]);
  stats_.peak_observations_in_memory = std::max(
      stats_.peak_observations_in_memory, static_cast<int64_t>(bucket_.size() + n));
  return Status::Ok();
}

}  // namespace graphslam::partition
