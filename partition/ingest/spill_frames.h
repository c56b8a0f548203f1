// Spill frames: how the external bucketing (partition/ingest/external_bucketing.h)
// writes runs of observations to its bucket scratch files -- compact,
// zstd-compressed, checksummed, and cut only between frames, so a bucket file
// can be truncated back to a checkpoint (docs/formats/spill_bucket.md).
//
// One frame per appended run of n observations:
//
//   [magic u32 "GSF1"][n u32][payload_bytes u32][masked crc32c u32][payload]
//
// payload = zstd(columns), columns = the n observations as arrays, 61 bytes
// per observation instead of the 72-byte struct with its padding:
//   pose    i32[n]  pose[i] - pose[i-1] (pose[-1] = 0, mod 2^32)
//   feature i32[n]
//   kind    u8[n]
//   z       f64[n] x 2        (all z(0), then all z(1))
//   information f64[n] x 4    (column-major entries, one array each)
//   line    i32[n]  line[i] - line[i-1] (line[-1] = 0, mod 2^32)
// Columns make the constant information and kind runs, and the slowly
// growing pose and line numbers, nearly free to zstd; the doubles are copied
// bit for bit, so a decoded observation equals the encoded one exactly
// (the store stays byte-identical). The CRC covers n, payload_bytes and the
// payload. Little-endian hosts only (as the chunk format's fast path).
//
// Errors name the file and the byte offset of the frame (bad magic, a frame
// running past the end of the file, a CRC mismatch, a payload that does not
// decompress to 61 * n bytes, an unknown kind).
//
// THREAD SAFETY: a SpillFrameEncoder / SpillFrameDecoder per thread.
// ALLOCATION: the encoder and decoder keep one frame's columns and payload
// (at most kMaxSpillFrameObservations when written by the bucketing).
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/problem.h"
#include "core/status.h"
#include "storage/env.h"

namespace graphslam::partition {

inline constexpr uint32_t kSpillFrameMagic = 0x31465347u;  // "GSF1" little-endian
inline constexpr size_t kSpillFrameHeaderBytes = 16;
inline constexpr size_t kSpillRecordBytes = 61;  // per observation, before zstd
// A run longer than this is written as several frames, so the encoders'
// scratch stays ~8 MB each however large the spill buffer is.
inline constexpr size_t kMaxSpillFrameObservations = size_t{1} << 16;
// The default zstd level of scratch frames (replay segments, bucket files),
// each written once and read once. At -1 zstd stores the literals raw: on
// the simulator's columns the frames are ~10 % larger than at level 1
// (0.31 vs 0.28 of the 61-byte columns), compress ~1.8x and decompress
// ~4x faster (docs/formats/spill_bucket.md).
inline constexpr int kSpillFrameZstdLevel = -1;

class SpillFrameEncoder {
 public:
  explicit SpillFrameEncoder(int zstd_level);
  ~SpillFrameEncoder();
  SpillFrameEncoder(const SpillFrameEncoder&) = delete;
  SpillFrameEncoder& operator=(const SpillFrameEncoder&) = delete;

  // Replaces *frame by the frame of observations[0, n) (n < 2^31).
  [[nodiscard]] Status Encode(const core::Observation* observations, size_t n,
                              std::vector<char>* frame);

 private:
  struct Context;
  int level_;
  std::unique_ptr<Context> context_;
  std::vector<char> columns_;
  std::vector<char> compressed_;
};

class SpillFrameDecoder {
 public:
  SpillFrameDecoder();
  ~SpillFrameDecoder();
  SpillFrameDecoder(const SpillFrameDecoder&) = delete;
  SpillFrameDecoder& operator=(const SpillFrameDecoder&) = delete;

  // Reads `path` (opened by the caller as `file`, positioned at its start) to
  // the end, appending every frame's observations to *out. Corruption naming
  // `path` and the frame's byte offset on any damage; IOError on a read error.
  [[nodiscard]] Status ReadFile(const std::string& path, storage::ReadableFile* file,
                                std::vector<core::Observation>* out);
  // One frame at *offset (the file positioned there): appends its
  // observations to *out, advances *offset; false at the end of the file.
  StatusOr<bool> ReadFrame(const std::string& path, storage::ReadableFile* file,
                           int64_t* offset, std::vector<core::Observation>* out);

  // The two halves of ReadFrame, so that frames read in order can be decoded
  // in parallel (a decoder per thread). ReadRawFrame: the frame's bytes
  // (header + payload) at `offset` (the file positioned there) into *frame,
  // checking magic and lengths; false at the end of the file.
  static StatusOr<bool> ReadRawFrame(const std::string& path, storage::ReadableFile* file,
                                     int64_t offset, std::vector<char>* frame);
  // Decodes the whole frame `frame[0, size)` (read from `path` at `offset`:
  // for messages) into out[0, n), n = FrameObservations(frame): CRC,
  // decompression, kinds checked.
  [[nodiscard]] Status DecodeFrame(const std::string& path, int64_t offset, const char* frame,
                                   size_t size, core::Observation* out);

 private:
  struct Context;
  std::unique_ptr<Context> context_;
  std::vector<char> frame_;
  std::vector<char> columns_;
};

// n of the frame whose (>= kSpillFrameHeaderBytes) bytes start at `frame`.
size_t FrameObservations(const char* frame);
// Header + payload bytes of that frame.
size_t FrameBytes(const char* frame);

// Where the frames of a whole spill file read into bytes[0, size) start
// (offsets[f]) and which observation each begins with (firsts[f]), from the
// headers alone; Corruption naming `path` and the offset for a damaged header
// or a truncated frame (the same checks as ReadRawFrame).
struct SpillFrameIndex {
  std::vector<size_t> offsets;
  std::vector<int64_t> firsts;
  int64_t observations = 0;  // in all frames
};
StatusOr<SpillFrameIndex> IndexSpillFrames(const std::string& path, const char* bytes,
                                           size_t size);

// The byte offset at which the first `observations` observations of the
// bucket file `path` end (a frame boundary), read from the frame headers
// alone: where a resumed spill truncates the file. Corruption naming the
// path and offset if the file is shorter, a header is damaged, or the count
// falls inside a frame.
StatusOr<int64_t> SpillFrameBoundary(const std::string& path, int64_t observations);

}  // namespace graphslam::partition
