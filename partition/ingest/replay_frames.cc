#include "partition/ingest/replay_frames.h"

#include <algorithm>
#include <atomic>
#include <cinttypes>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <mutex>
#include <string_view>
#include <utility>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_pipeline.h>

#include "partition/ingest/spill_frames.h"
#include "storage/env.h"

namespace graphslam::partition {

Status ReplayFrameOptions::Validate() const {
  if (frame_observations <= 0 ||
      frame_observations > static_cast<int64_t>(kMaxSpillFrameObservations))
    return Status::InvalidArgument("replay frame_observations must be in 1.." +
                                   std::to_string(kMaxSpillFrameObservations) + ", got " +
                                   std::to_string(frame_observations));
  if (frames_per_segment <= 0)
    return Status::InvalidArgument("replay frames_per_segment must be > 0, got " +
                                   std::to_string(frames_per_segment));
  return Status::Ok();
}

std::string ReplaySegmentPath(const std::string& work_dir, int64_t segment) {
  char name[40];
  std::snprintf(name, sizeof(name), "replay_%06" PRId64 ".bin", segment);
  return (std::filesystem::path(work_dir) / name).string();
}

ReplayFrameWriter::ReplayFrameWriter(std::string work_dir, const ReplayFrameOptions& options)
    : work_dir_(std::move(work_dir)), options_(options) {
  GS_CHECK(options_.Validate().ok());
  filling_.reserve(static_cast<size_t>(options_.frame_observations));
  thread_ = std::thread([this] { Run(); });
}

ReplayFrameWriter::~ReplayFrameWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = true;
  }
  changed_.notify_all();
  if (thread_.joinable()) thread_.join();
}

Status ReplayFrameWriter::Add(const core::Observation& observation) {
  filling_.push_back(observation);
  ++observations_;
  if (static_cast<int64_t>(filling_.size()) < options_.frame_observations) return Status::Ok();
  return Enqueue();
}

// Hands the filled frame to the thread (waiting while kReplayFramesInFlight
// are queued: memory stays bounded when the disk is slower than the parse)
// and takes a spare vector to fill next.
Status ReplayFrameWriter::Enqueue() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return queue_.size() < kReplayFramesInFlight || !error_.ok(); });
  if (!error_.ok()) return error_;
  queue_.push_back(std::move(filling_));
  if (!spare_.empty()) {
    filling_ = std::move(spare_.back());
    spare_.pop_back();
  } else {
    filling_ = std::vector<core::Observation>();
    filling_.reserve(static_cast<size_t>(options_.frame_observations));
  }
  filling_.clear();
  lock.unlock();
  changed_.notify_all();
  return Status::Ok();
}

void ReplayFrameWriter::Run() {
  while (true) {
    std::vector<core::Observation> frame;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return !queue_.empty() || done_; });
      if (queue_.empty()) return;  // done_
      frame = std::move(queue_.front());
      queue_.pop_front();
      // An error drops the rest: the writer reports the first one.
      if (!error_.ok()) continue;
    }
    Status status = WriteFrame(frame);
    frame.clear();
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (error_.ok() && !status.ok()) error_ = std::move(status);
      spare_.push_back(std::move(frame));
    }
    changed_.notify_all();
  }
}

Status ReplayFrameWriter::WriteFrame(const std::vector<core::Observation>& frame) {
  // One encoder for the writer's lifetime (its zstd context is reused).
  if (!encoder_) encoder_ = std::make_unique<SpillFrameEncoder>(options_.zstd_level);
  std::vector<char>& bytes = bytes_;
  GS_RETURN_IF_ERROR(encoder_->Encode(frame.data(), frame.size(), &bytes));
  if (segment_ == nullptr) {
    ++segment_index_;
    GS_ASSIGN_OR_RETURN(segment_, storage::Env::Default()->NewWritableFile(
                                      ReplaySegmentPath(work_dir_, segment_index_)));
    frames_in_segment_ = 0;
  }
  GS_RETURN_IF_ERROR(segment_->Append(std::string_view(bytes.data(), bytes.size())));
  bytes_written_ += static_cast<int64_t>(bytes.size());
  if (++frames_in_segment_ == options_.frames_per_segment) return CloseSegment();
  return Status::Ok();
}

// Flushes, fsyncs and closes the open segment (durable before any progress
// record counts it; one segment at a time keeps the writeback steady).
Status ReplayFrameWriter::CloseSegment() {
  if (segment_ == nullptr) return Status::Ok();
  const std::unique_ptr<storage::WritableFile> file = std::move(segment_);
  GS_RETURN_IF_ERROR(file->Sync());
  return file->Close();
}

Status ReplayFrameWriter::Finish() {
  if (!filling_.empty()) GS_RETURN_IF_ERROR(Enqueue());
  {
    std::lock_guard<std::mutex> lock(mutex_);
    done_ = true;
  }
  changed_.notify_all();
  thread_.join();  // drains the queue first
  GS_RETURN_IF_ERROR(error_);
  return CloseSegment();
}

namespace {

// One frame of the replay on its way through the pipeline below.
struct ReplayBlock {
  std::string path;  // its segment
  int64_t offset = 0;
  std::vector<char> raw;
  std::vector<core::Observation> observations;
  int64_t end_position = 0;
  Status status;
};

// The serial first stage: the frames' bytes, in order, from `start` on.
class RawFrameReader {
 public:
  RawFrameReader(std::string work_dir, const ReplayFrameOptions& options, int64_t start,
                 int64_t total)
      : work_dir_(std::move(work_dir)), per_segment_(options.segment_observations()),
        position_(start), total_(total) {}

  // The next frame into *block; false when `total` is reached.
  StatusOr<bool> Next(ReplayBlock* block) {
    if (position_ >= total_) return false;
    const int64_t segment = position_ / per_segment_;
    if (file_ == nullptr || segment != segment_) {
      file_.reset();
      segment_ = segment;
      path_ = ReplaySegmentPath(work_dir_, segment);
      // The frame boundary after the segment's observations already replayed.
      GS_ASSIGN_OR_RETURN(offset_, SpillFrameBoundary(path_, position_ % per_segment_));
      StatusOr<std::unique_ptr<storage::ReadableFile>> file =
          storage::Env::Default()->NewReadableFile(path_);
      if (!file.ok()) {
        if (file.status().IsNotFound())
          return Status::Corruption(path_ + ": missing; the replay needs observations " +
                                    std::to_string(position_) + ".." +
                                    std::to_string(total_ - 1) + " of pass 1");
        return file.status();
      }
      file_ = std::move(file).value();
      GS_RETURN_IF_ERROR(file_->Seek(static_cast<uint64_t>(offset_)));
    }
    const int64_t segment_end = std::min(total_, (segment_ + 1) * per_segment_);
    GS_ASSIGN_OR_RETURN(const bool more,
                        SpillFrameDecoder::ReadRawFrame(path_, file_.get(), offset_, &block->raw));
    const int64_t n = more ? static_cast<int64_t>(FrameObservations(block->raw.data())) : 0;
    if (!more || position_ + n > segment_end)
      return Status::Corruption(path_ + ": spill frame at byte " + std::to_string(offset_) + ": " +
                                (more ? "runs past" : "the segment ends before") +
                                " replay position " + std::to_string(segment_end) +
                                "; expected segments of " + std::to_string(per_segment_) +
                                " observations and " + std::to_string(total_) + " in all");
    block->path = path_;
    block->offset = offset_;
    offset_ += static_cast<int64_t>(block->raw.size());
    position_ += n;
    block->end_position = position_;
    return true;
  }

 private:
  const std::string work_dir_;
  const int64_t per_segment_;
  int64_t position_;
  const int64_t total_;
  std::unique_ptr<storage::ReadableFile> file_;
  int64_t segment_ = -1;
  std::string path_;
  int64_t offset_ = 0;
};

}  // namespace

ObservationBlockReplay ReplayFrames(const std::string& work_dir, const ReplayFrameOptions& options,
                                    int64_t start, int64_t total, int64_t* bytes_read) {
  return [work_dir, options, start, total, bytes_read](const ObservationBlockSink& sink) -> Status {
    GS_RETURN_IF_ERROR(options.Validate());
    // serial: read a frame's bytes; parallel: CRC + zstd + columns (a
    // decoder per thread); serial in order: the sink (the spill). The
    // decoding overlaps the spill; at most kReplayFramesInFlight frames live.
    RawFrameReader reader(work_dir, options, start, total);
    tbb::enumerable_thread_specific<SpillFrameDecoder> decoders;
    std::vector<std::unique_ptr<ReplayBlock>> pool;  // first stage only
    std::mutex pool_mutex;
    Status read_failure;              // first stage only
    Status sink_failure;              // last stage only
    std::atomic<bool> failed{false};  // read by the first stage, set by both
    tbb::parallel_pipeline(
        kReplayFramesInFlight,
        tbb::make_filter<void, ReplayBlock*>(
            tbb::filter_mode::serial_in_order,
            [&](tbb::flow_control& control) -> ReplayBlock* {
              std::unique_ptr<ReplayBlock> block;
              {
                std::lock_guard<std::mutex> lock(pool_mutex);
                if (!pool.empty()) {
                  block = std::move(pool.back());
                  pool.pop_back();
                }
              }
              if (!block) block = std::make_unique<ReplayBlock>();
              StatusOr<bool> more = failed ? StatusOr<bool>(false) : reader.Next(block.get());
              if (!more.ok() || !*more) {
                if (!more.ok()) {
                  read_failure = more.status();
                  failed = true;
                }
                control.stop();
                return nullptr;
              }
              return block.release();
            }) &
            tbb::make_filter<ReplayBlock*, ReplayBlock*>(
                tbb::filter_mode::parallel,
                [&](ReplayBlock* block) -> ReplayBlock* {
                  block->observations.resize(FrameObservations(block->raw.data()));
                  block->status = decoders.local().DecodeFrame(
                      block->path, block->offset, block->raw.data(), block->raw.size(),
                      block->observations.data());
                  return block;
                }) &
            tbb::make_filter<ReplayBlock*, void>(
                tbb::filter_mode::serial_in_order, [&](ReplayBlock* raw) {
                  std::unique_ptr<ReplayBlock> block(raw);
                  if (!failed) {
                    Status status = block->status;
                    if (status.ok()) {
                      if (bytes_read != nullptr)
                        *bytes_read += static_cast<int64_t>(block->raw.size());
                      ObservationBlock view;
                      view.observations = block->observations.data();
                      view.size = block->observations.size();
                      view.end_offset = block->end_position;
                      status = sink(view);
                    }
                    if (!status.ok()) {
                      sink_failure = std::move(status);
                      failed = true;
                    }
                  }
                  std::lock_guard<std::mutex> lock(pool_mutex);
                  pool.push_back(std::move(block));
                }));
    return !sink_failure.ok() ? sink_failure : read_failure;
  };
}

void ReleaseReplaySegmentsBefore(const std::string& work_dir, const ReplayFrameOptions& options,
                                 int64_t position) {
  const int64_t end = position / options.segment_observations();
  for (int64_t segment = end - 1; segment >= 0; --segment) {
    // Deleted downwards until one is gone already: the earlier ones went before it.
    if (!storage::Env::Default()->RemoveFile(ReplaySegmentPath(work_dir, segment)).ok()) break;
  }
}

}  // namespace graphslam::partition
