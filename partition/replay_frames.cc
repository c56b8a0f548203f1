#include "partition/replay_frames.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "partition/spill_frames.h"

namespace graphslam::partition {
namespace {

Status IoError(const std::string& path, const char* what) {
  return Status::IOError(path + ": " + what + ": " + std::strerror(errno));
}

}  // namespace

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
  if (segment_ != nullptr) std::fclose(segment_);
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
    const std::string path = ReplaySegmentPath(work_dir_, segment_index_);
    segment_ = std::fopen(path.c_str(), "wb");
    if (segment_ == nullptr) return IoError(path, "open for writing");
    frames_in_segment_ = 0;
  }
  if (std::fwrite(bytes.data(), 1, bytes.size(), segment_) != bytes.size())
    return IoError(ReplaySegmentPath(work_dir_, segment_index_), "write");
  bytes_written_ += static_cast<int64_t>(bytes.size());
  if (++frames_in_segment_ == options_.frames_per_segment) return CloseSegment();
  return Status::Ok();
}

// Flushes, fsyncs and closes the open segment (durable before any progress
// record counts it; one segment at a time keeps the writeback steady).
Status ReplayFrameWriter::CloseSegment() {
  if (segment_ == nullptr) return Status::Ok();
  const std::string path = ReplaySegmentPath(work_dir_, segment_index_);
  std::FILE* file = segment_;
  segment_ = nullptr;
  Status status;
  if (std::fflush(file) != 0) status = IoError(path, "write");
  if (status.ok() && ::fsync(::fileno(file)) != 0) status = IoError(path, "fsync");
  if (std::fclose(file) != 0 && status.ok()) status = IoError(path, "close");
  return status;
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

ObservationBlockReplay ReplayFrames(const std::string& work_dir, const ReplayFrameOptions& options,
                                    int64_t start, int64_t total, int64_t* bytes_read) {
  return [work_dir, options, start, total, bytes_read](const ObservationBlockSink& sink) -> Status {
    GS_RETURN_IF_ERROR(options.Validate());
    const int64_t per_segment = options.segment_observations();
    int64_t position = start;
    SpillFrameDecoder decoder;
    std::vector<core::Observation> frame;
    while (position < total) {
      const int64_t segment = position / per_segment;
      const std::string path = ReplaySegmentPath(work_dir, segment);
      // The frame boundary after the segment's observations already replayed.
      GS_ASSIGN_OR_RETURN(int64_t offset, SpillFrameBoundary(path, position % per_segment));
      std::FILE* file = std::fopen(path.c_str(), "rb");
      if (file == nullptr) {
        if (errno == ENOENT)
          return Status::Corruption(path + ": missing; the replay needs observations " +
                                    std::to_string(position) + ".." + std::to_string(total - 1) +
                                    " of pass 1");
        return IoError(path, "open for reading");
      }
      std::unique_ptr<std::FILE, int (*)(std::FILE*)> closer(file, &std::fclose);
      if (std::fseek(file, offset, SEEK_SET) != 0) return IoError(path, "seek");
      const int64_t segment_end = std::min(total, (segment + 1) * per_segment);
      while (position < segment_end) {
        const int64_t frame_offset = offset;
        frame.clear();
        GS_ASSIGN_OR_RETURN(const bool more, decoder.ReadFrame(path, file, &offset, &frame));
        if (!more || position + static_cast<int64_t>(frame.size()) > segment_end)
          return Status::Corruption(path + ": spill frame at byte " + std::to_string(frame_offset) +
                                    ": " + (more ? "runs past" : "the segment ends before") +
                                    " replay position " + std::to_string(segment_end) +
                                    "; expected segments of " + std::to_string(per_segment) +
                                    " observations and " + std::to_string(total) + " in all");
        if (bytes_read != nullptr) *bytes_read += offset - frame_offset;
        position += static_cast<int64_t>(frame.size());
        ObservationBlock block;
        block.observations = frame.data();
        block.size = frame.size();
        block.end_offset = position;
        GS_RETURN_IF_ERROR(sink(block));
      }
    }
    return Status::Ok();
  };
}

void ReleaseReplaySegmentsBefore(const std::string& work_dir, const ReplayFrameOptions& options,
                                 int64_t position) {
  const int64_t end = position / options.segment_observations();
  for (int64_t segment = end - 1; segment >= 0; --segment) {
    std::error_code error;
    // Deleted downwards until one is gone already: the earlier ones went before it.
    if (!std::filesystem::remove(ReplaySegmentPath(work_dir, segment), error)) break;
  }
}

}  // namespace graphslam::partition
