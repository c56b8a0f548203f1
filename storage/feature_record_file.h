// Feature record files: per-feature solver state on disk, as framed,
// checksummed records (docs/formats/feature_state.md). Two kinds share the
// framing:
//
//   candidates   (kind 1, storage/candidate_file.h) one record per chunk:
//                chunk:i64 count:u32 feature:i32[count] value:f64[count * D]
//   checkpoint   (kind 2, storage/solver_checkpoint.h) the feature estimates
//                and flags of a checkpoint, in feature order, in records of
//                up to 65536 features:
//                first:i64 count:u32 value:f64[count * D] excluded:u8[count]
//                kept:u8[count]
//   solver state (kind 3, storage/solver_state_file.h) the poses and the PCG
//                state of a checkpoint
//   feature ids  (kind 4, storage/feature_id_file.h) a streaming solve's ids,
//                parked while it runs
//
//   file    := header record* footer                      (little-endian)
//   header  := magic[8] version:u32 kind:u32 dimension:u32 header_crc:u32
//              (24 bytes; header_crc = Mask(CRC32C(bytes [0, 20))))
//   record  := length:u32 type:u8 crc:u32 payload[length]
//              crc = Mask(CRC32C(type byte || payload))   (as chunk files)
//   footer  := a record of type 2: records:u64 items:u64
//
// A reader checks every CRC, that the footer is the last record and ends the
// file, and its counts; a damaged or truncated file is Corruption naming the
// file and the byte offset of the bad record.
//
// THREAD SAFETY: a writer or reader is used by one thread. ALLOCATION: the
// record being written or read.
#pragma once

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>

#include "core/status.h"
#include "storage/env.h"

namespace graphslam::storage::feature_records {

// "\x89GSF\r\n\x1a\n" as a little-endian u64 (the chunk files' trick).
inline constexpr uint64_t kMagic = 0x0A1A0A0D46534789ull;
inline constexpr uint32_t kVersion = 1;
inline constexpr uint32_t kKindCandidates = 1;
inline constexpr uint32_t kKindCheckpoint = 2;
inline constexpr uint32_t kKindSolverState = 3;  // storage/solver_state_file.h
inline constexpr uint32_t kKindFeatureIds = 4;   // storage/feature_id_file.h
inline constexpr size_t kHeaderSize = 24;
inline constexpr size_t kRecordHeaderSize = 9;
inline constexpr uint8_t kData = 1;
inline constexpr uint8_t kFooter = 2;
inline constexpr size_t kMaxRecordLength = size_t{1} << 28;

std::string EncodeHeader(uint32_t kind, uint32_t dimension);
// Appends one framed record of `type` to *out.
void AppendRecord(uint8_t type, std::string_view payload, std::string* out);
std::string EncodeFooter(uint64_t records, uint64_t items);

// Sequential reader with validation (see the header comment).
class Reader {
 public:
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // Opens `path` and checks the header's magic, version, kind and dimension.
  static StatusOr<std::unique_ptr<Reader>> Open(const std::string& path, uint32_t kind,
                                                uint32_t dimension);

  // The next data record's payload into *payload (true), or false after the
  // footer, whose counts must equal `records` read and `items` (the caller's
  // count of what the records held).
  StatusOr<bool> Next(std::string* payload, uint64_t items);

  // Byte offset of the record last returned (for the caller's errors).
  int64_t record_offset() const { return record_offset_; }
  const std::string& path() const { return path_; }
  // Corruption "path: offset N: what".
  Status Bad(int64_t offset, const std::string& what) const;

 private:
  Reader(std::string path, std::FILE* file) : path_(std::move(path)), file_(file) {}
  std::string path_;
  std::FILE* file_ = nullptr;
  int64_t offset_ = 0;
  int64_t record_offset_ = 0;
  uint64_t records_ = 0;
  bool done_ = false;
};

}  // namespace graphslam::storage::feature_records
