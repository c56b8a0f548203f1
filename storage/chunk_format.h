// The on-disk layout of one observation chunk (a core::ObservationChunk), as
// specified in docs/formats/observation_chunk.md; shared by chunk_writer.h and
// chunk_reader.h. The design follows LevelDB's log format (db/log_format.h,
// doc/log_format.md): a fixed header, then framed records, each checksummed
// with a masked CRC32C (storage/crc32c.h), so that a reader can name the record
// and byte offset of any damage and, if asked, skip just the damaged record.
//
//   file    := header  feature_block*  footer                 (little-endian)
//   header  := magic[8] version:u32 flags:u32 chunk_index:i64
//              num_features:i64 num_observations:i64 reserved:u32
//              header_crc:u32                                 (48 bytes)
//   record  := length:u32 type:u8 crc:u32 payload[length]      (9 + length)
//              crc = Mask(CRC32C(type byte || payload))
//   feature_block payload (type 1; type 0x81 = the same, zstd-compressed as
//              uncompressed_length:u32 zstd_frame):
//              first_feature_slot:i64 first_observation:i64 feature_count:u32
//              { feature:i32 observation_count:u32 } * feature_count
//              then, N = sum(observation_count):
//     version 1: observation * N, each
//                pose:i32 feature:i32 kind:u8 z[2]:f64
//                information[4]:f64 (column-major) line:i32  (61 bytes)
//     version 2: columns, the feature implied by the table:
//                information_count:u32 I, information[4]:f64 * I (the table)
//                pose_delta:i32 * N   kind:u8 * N   z0:f64 * N   z1:f64 * N
//                information_index * N (u8 if 1 < I <= 256 and I != N,
//                u16 if 256 < I <= 65536 and I != N, absent otherwise)
//                line_delta:i32 * N                       (25-27 bytes each)
//              Deltas are against the block's previous observation (the
//              first against 0), in wrapping 32-bit arithmetic, so every i32
//              round-trips; the per-feature runs of poses and source lines are
//              ascending, and small deltas compress far better than values.
//              Without an index column observation i uses entry 0 (I == 1) or
//              entry i (I == N: every observation its own entry, the fallback
//              when informations mostly differ).
//              kind: a model of core/observation_models.h, which says how
//              that model fills z and the information.
//   footer payload (type 2, never compressed, last record of the file):
//              num_features:i64 num_observations:i64 num_blocks:u32
//              chain_crc:u32 = Mask(CRC32C(header_crc || crc of each block))
//
// A block holds whole features only (a chunk is feature-complete and each of
// its features stays in one record), so dropping a damaged record in
// non-paranoid mode still leaves a consistent chunk: fewer features, each
// complete.
//
// THREAD SAFETY: constants and pure inline functions. ALLOCATION: none.
#pragma once

#include <bit>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "core/problem.h"

namespace graphslam::storage::chunk_format {

// "\x89GSC\r\n\x1a\n" read as a little-endian u64: the high first byte catches
// 7-bit transfers, CR LF / LF catch newline translation, 0x1A stops a DOS
// `type` (the PNG signature trick).
inline constexpr uint64_t kMagic = 0x0A1A0A0D43534789ull;
// What writers write; readers read every version from 1 to this one.
inline constexpr uint32_t kFormatVersion = 2;
inline constexpr uint32_t kColumnarVersion = 2;  // the first with columnar blocks

// Header flags. A reader rejects unknown bits (NotSupported).
inline constexpr uint32_t kFlagZstd = 1u << 0;  // blocks may be zstd-compressed
inline constexpr uint32_t kKnownFlags = kFlagZstd;

inline constexpr size_t kHeaderSize = 48;
inline constexpr size_t kHeaderCrcOffset = 44;  // the CRC covers bytes [0, 44)
inline constexpr size_t kRecordHeaderSize = 9;  // length u32, type u8, crc u32

// Record types. 0 is never written, so a zeroed region is never a valid record.
inline constexpr uint8_t kFeatureBlock = 1;
inline constexpr uint8_t kFooter = 2;
inline constexpr uint8_t kCompressedBit = 0x80;  // only on kFeatureBlock

inline constexpr size_t kBlockHeaderSize = 20;   // first slot, first obs, count
inline constexpr size_t kFeatureEntrySize = 8;   // feature i32, count u32
inline constexpr size_t kObservationSize = 61;   // version 1, per observation
inline constexpr size_t kFooterSize = 24;

// Version 2: the information table's count, one table entry, and the columns
// of one observation without its information index (pose, kind, z, line).
inline constexpr size_t kInformationCountSize = 4;
inline constexpr size_t kInformationSize = 32;
inline constexpr size_t kColumnsSize = 25;
// The most table entries an index column addresses (u16); above it a writer
// falls back to one entry per observation.
inline constexpr size_t kMaxIndexedInformations = 65536;

// Version 2: bytes of one observation's information index for a block with
// `informations` table entries and `observations` observations (0: no
// column), or -1 when no writer makes that table (more entries than
// observations, none for a non-empty block, or too many to index and not one
// per observation).
inline int InformationIndexWidth(uint64_t informations, uint64_t observations) {
  if (informations > observations) return -1;
  if (informations == 0) return observations == 0 ? 0 : -1;
  if (informations == 1 || informations == observations) return 0;
  if (informations <= 256) return 1;
  if (informations <= kMaxIndexedInformations) return 2;
  return -1;
}

// Largest payload (and largest uncompressed feature block) a writer emits or a
// reader accepts: bounds what a corrupt length can make a reader allocate.
// 256 MiB holds a single feature with about 4.4 million observations.
inline constexpr size_t kMaxRecordLength = size_t{1} << 28;

// --- little-endian encoding, independent of the host's byte order ---------

// Little-endian encoders into a caller's buffer; they return the end. On a
// little-endian host a memcpy is that byte order already (the chunk writer
// encodes ~40 M observations per 10^7-feature ingest: no byte-wise appends).
inline char* EncodeFixed32(char* p, uint32_t value) {
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(p, &value, 4);
  } else {
    for (int i = 0; i < 4; ++i) p[i] = static_cast<char>((value >> (8 * i)) & 0xFFu);
  }
  return p + 4;
}
inline char* EncodeFixed64(char* p, uint64_t value) {
  if constexpr (std::endian::native == std::endian::little) {
    std::memcpy(p, &value, 8);
  } else {
    for (int i = 0; i < 8; ++i) p[i] = static_cast<char>((value >> (8 * i)) & 0xFFu);
  }
  return p + 8;
}
inline void PutFixed32(std::string* out, uint32_t value) {
  char bytes[4];
  out->append(bytes, static_cast<size_t>(EncodeFixed32(bytes, value) - bytes));
}
inline void PutFixed64(std::string* out, uint64_t value) {
  char bytes[8];
  out->append(bytes, static_cast<size_t>(EncodeFixed64(bytes, value) - bytes));
}
inline void PutDouble(std::string* out, double value) {
  PutFixed64(out, std::bit_cast<uint64_t>(value));  // bit-exact, -0.0 included
}
inline uint32_t DecodeFixed32(const char* p) {
  const auto* u = reinterpret_cast<const unsigned char*>(p);
  return static_cast<uint32_t>(u[0]) | (static_cast<uint32_t>(u[1]) << 8) |
         (static_cast<uint32_t>(u[2]) << 16) | (static_cast<uint32_t>(u[3]) << 24);
}
inline uint64_t DecodeFixed64(const char* p) {
  return static_cast<uint64_t>(DecodeFixed32(p)) |
         (static_cast<uint64_t>(DecodeFixed32(p + 4)) << 32);
}
inline double DecodeDouble(const char* p) { return std::bit_cast<double>(DecodeFixed64(p)); }

// --- one observation ----------------------------------------------------

inline void PutObservation(std::string* out, const core::Observation& observation) {
  char bytes[kObservationSize];
  char* p = EncodeFixed32(bytes, static_cast<uint32_t>(observation.pose));
  p = EncodeFixed32(p, static_cast<uint32_t>(observation.feature));
  *p++ = static_cast<char>(observation.kind);
  p = EncodeFixed64(p, std::bit_cast<uint64_t>(observation.z[0]));
  p = EncodeFixed64(p, std::bit_cast<uint64_t>(observation.z[1]));
  for (int i = 0; i < 4; ++i)
    p = EncodeFixed64(p, std::bit_cast<uint64_t>(observation.information.data()[i]));
  p = EncodeFixed32(p, static_cast<uint32_t>(observation.line));
  out->append(bytes, static_cast<size_t>(p - bytes));  // kObservationSize
}

// Decodes kObservationSize bytes. The kind byte is copied as is: check it
// with DescribeInvalidObservation before using the value.
inline void DecodeObservation(const char* p, core::Observation* observation) {
  observation->pose = static_cast<int32_t>(DecodeFixed32(p));
  observation->feature = static_cast<int32_t>(DecodeFixed32(p + 4));
  observation->kind = static_cast<core::ObservationKind>(static_cast<uint8_t>(p[8]));
  observation->z[0] = DecodeDouble(p + 9);
  observation->z[1] = DecodeDouble(p + 17);
  for (int i = 0; i < 4; ++i) observation->information.data()[i] = DecodeDouble(p + 25 + 8 * i);
  observation->line = static_cast<int32_t>(DecodeFixed32(p + 57));
}

// Whether DescribeInvalidObservation(observation, expected_feature) is "":
// the reader's per-observation test, without building a string (which was
// ~2 % of a streaming pass; perf, store1e7).
inline bool IsValidObservation(const core::Observation& observation,
                               int32_t expected_feature) {
  const auto kind = static_cast<uint8_t>(observation.kind);
  bool finite = std::isfinite(observation.z[0]) && std::isfinite(observation.z[1]);
  for (int i = 0; i < 4; ++i) finite = finite && std::isfinite(observation.information.data()[i]);
  return observation.feature == expected_feature && observation.pose >= 0 &&
         core::IsObservationKind(kind) && finite;
}

// "" when `observation` may be stored in the slot of feature `expected_feature`,
// else what is wrong with it, with expected and actual values. Shared by the
// writer (InvalidArgument) and the reader (Corruption) so both enforce the
// same rules (docs/formats/observation_chunk.md, "Validity").
inline std::string DescribeInvalidObservation(const core::Observation& observation,
                                              int32_t expected_feature) {
  if (observation.feature != expected_feature) {
    return "feature is " + std::to_string(observation.feature) + ", expected " +
           std::to_string(expected_feature) + " (the feature of its slot)";
  }
  if (observation.pose < 0) {
    return "pose " + std::to_string(observation.pose) + " is negative";
  }
  const auto kind = static_cast<uint8_t>(observation.kind);
  if (!core::IsObservationKind(kind)) {
    return "kind " + std::to_string(kind) + " is not an ObservationKind (expected " +
           core::ObservationKindRange() + ")";
  }
  for (int i = 0; i < 2; ++i) {
    if (!std::isfinite(observation.z[i])) return "z[" + std::to_string(i) + "] is not finite";
  }
  for (int i = 0; i < 4; ++i) {
    if (!std::isfinite(observation.information.data()[i])) {
      return "information(" + std::to_string(i % 2) + "," + std::to_string(i / 2) +
             ") is not finite";
    }
  }
  return "";
}

}  // namespace graphslam::storage::chunk_format
