// Replay frames: pass 1 of the out-of-core ingest (partition/ingest/streaming_ingest.h)
// keeps the observations it parsed, so that pass 2 reads them back as binary
// instead of reading, decompressing and parsing the input text a second time
// (docs/formats/spill_bucket.md "Replay segments").
//
//   STORE/work/replay_NNNNNN.bin   segment k: observations [k * S, (k+1) * S)
//                                  of the input, in input order, as spill
//                                  frames (partition/ingest/spill_frames.h: 61-byte
//                                  columns, zstd, CRC32C) of F observations
//                                  each (the last one of the input shorter);
//                                  S = F * frames_per_segment.
//
// The decoded observations equal the parsed ones bit for bit (the frames copy
// the doubles' bits), so pass 2 fills the buckets exactly as a re-parse did
// and the store stays byte-identical. Because every segment holds exactly S
// observations (but the last), replay position P (an observation count) lies
// in segment P / S at the frame boundary after P mod S observations (found
// from the frame headers, SpillFrameBoundary): pass 2 resumes there.
//
// Writing: frames are compressed and appended by a background thread (at most
// kReplayFramesInFlight frames queued), so the serial stage of pass 1 only
// copies observations; every segment is fsynced when it is closed, so after
// Finish all are durable (before the first progress record names them).
// Reading: a segment is deleted by the caller once the buckets holding its
// observations are durable (ReleaseReplaySegmentsBefore): scratch disk holds
// the replay not yet spilled, not all of it.
//
// THREAD SAFETY: one writer / one reader per work folder, each used by one
// thread. ALLOCATION: writer <= kReplayFramesInFlight + 2 frames of F
// observations (72 B each) plus one encoder's scratch; reader one frame.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "core/problem.h"
#include "core/status.h"
#include "partition/ingest/external_bucketing.h"
#include "partition/ingest/spill_frames.h"
#include "storage/env.h"

namespace graphslam::partition {

struct ReplayFrameOptions {
  int64_t frame_observations = 65536;  // F (<= kMaxSpillFrameObservations)
  int64_t frames_per_segment = 16;     // S / F: ~1 M observations, ~20 MB a segment
  // zstd level of the frames (scratch: read back once). Negative levels keep
  // the literals raw, so decoding is several times faster than at level 1
  // (kSpillFrameZstdLevel, spill_frames.h).
  int zstd_level = kSpillFrameZstdLevel;

  int64_t segment_observations() const { return frame_observations * frames_per_segment; }
  [[nodiscard]] Status Validate() const;
};

inline constexpr size_t kReplayFramesInFlight = 4;

// The path of segment `segment` in `work_dir`.
std::string ReplaySegmentPath(const std::string& work_dir, int64_t segment);

class ReplayFrameWriter {
 public:
  // Starts the background thread; `work_dir` must exist and hold no segments.
  ReplayFrameWriter(std::string work_dir, const ReplayFrameOptions& options);
  ~ReplayFrameWriter();  // stops the thread (what was not Finished is scratch)
  ReplayFrameWriter(const ReplayFrameWriter&) = delete;
  ReplayFrameWriter& operator=(const ReplayFrameWriter&) = delete;

  // Appends one observation (in input order). Returns the background
  // thread's first error (IOError naming the segment), if any yet.
  [[nodiscard]] Status Add(const core::Observation& observation);
  // Writes the last frame, waits for the thread, fsyncs: then every segment
  // is complete and durable. Returns the first error.
  [[nodiscard]] Status Finish();

  int64_t observations() const { return observations_; }
  int64_t bytes_written() const { return bytes_written_; }  // valid after Finish

 private:
  void Run();
  Status WriteFrame(const std::vector<core::Observation>& frame);
  Status CloseSegment();
  Status Enqueue();

  const std::string work_dir_;
  const ReplayFrameOptions options_;
  std::vector<core::Observation> filling_;
  int64_t observations_ = 0;

  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::vector<core::Observation>> queue_;  // guarded by mutex_
  std::vector<std::vector<core::Observation>> spare_;  // guarded by mutex_
  bool done_ = false;                                  // guarded by mutex_
  Status error_;                                       // guarded by mutex_
  std::thread thread_;

  // Background thread only (read by Finish after the join).
  std::unique_ptr<SpillFrameEncoder> encoder_;
  std::vector<char> bytes_;
  std::unique_ptr<storage::WritableFile> segment_;
  int64_t segment_index_ = -1;
  int64_t frames_in_segment_ = 0;
  int64_t bytes_written_ = 0;
};

// An ObservationBlockReplay over the segments from replay position `start`
// (observations already spilled) to `total`: one block per frame, whose
// end_offset is the replay position after it. Errors: Corruption naming the
// segment and the frame's byte offset (damage, a missing segment, counts
// that do not add up), IOError.
ObservationBlockReplay ReplayFrames(const std::string& work_dir, const ReplayFrameOptions& options,
                                    int64_t start, int64_t total, int64_t* bytes_read);

// Deletes the segments all of whose observations lie before replay position
// `position` (a leftover is harmless scratch).
void ReleaseReplaySegmentsBefore(const std::string& work_dir, const ReplayFrameOptions& options,
                                 int64_t position);

}  // namespace graphslam::partition
