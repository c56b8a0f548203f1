// Writer of docs/formats/observation_chunk.md; section names below refer to it.
#include "storage/chunk_writer.h"

#include <zstd.h>

#include <cstring>
#include <memory>
#include <string_view>
#include <unordered_map>
#include <vector>

#include "storage/atomic_file.h"
#include "storage/chunk_format.h"
#include "storage/crc32c.h"

namespace graphslam::storage {
namespace {

namespace format = chunk_format;

std::string SlotName(int64_t slot, int32_t feature) {
  return "feature slot " + std::to_string(slot) + " (feature " + std::to_string(feature) + ")";
}

// "Header": 48 bytes, the CRC over the first 44.
std::string EncodeHeader(const core::ObservationChunk& chunk, uint32_t version, uint32_t flags) {
  std::string header;
  header.reserve(format::kHeaderSize);
  format::PutFixed64(&header, format::kMagic);
  format::PutFixed32(&header, version);
  format::PutFixed32(&header, flags);
  format::PutFixed64(&header, static_cast<uint64_t>(chunk.index));
  format::PutFixed64(&header, static_cast<uint64_t>(chunk.features.size()));
  format::PutFixed64(&header, static_cast<uint64_t>(chunk.observations.size()));
  format::PutFixed32(&header, 0);  // reserved
  format::PutFixed32(&header, crc32c::Mask(crc32c::Value(header)));
  GS_CHECK(header.size() == format::kHeaderSize);
  return header;
}

// "Records": the 9-byte frame of `payload`; returns the masked CRC it stored.
uint32_t EncodeRecordHeader(uint8_t type, std::string_view payload, std::string* out) {
  const char type_byte = static_cast<char>(type);
  const uint32_t crc =
      crc32c::Mask(crc32c::Extend(crc32c::Value(&type_byte, 1), payload.data(), payload.size()));
  out->clear();
  format::PutFixed32(out, static_cast<uint32_t>(payload.size()));
  out->push_back(type_byte);
  format::PutFixed32(out, crc);
  return crc;
}

// "Feature block": the uncompressed size of a block of `num_features`
// features, exact for version 1; for version 2 the largest it can be (each
// observation with a table entry of its own and no index column: the writer
// never picks an index that costs more than that).
size_t BlockBytes(uint32_t version, size_t num_features, int64_t num_observations) {
  const size_t per_observation = version >= format::kColumnarVersion
                                     ? format::kColumnsSize + format::kInformationSize
                                     : format::kObservationSize;
  const size_t table = version >= format::kColumnarVersion ? format::kInformationCountSize : 0;
  return format::kBlockHeaderSize + format::kFeatureEntrySize * num_features + table +
         per_observation * static_cast<size_t>(num_observations);
}

// An information matrix as its four bit patterns: equal bits, equal entry
// (-0.0 and 0.0 stay distinct, so decoding is bit-exact).
struct InformationBits {
  uint64_t word[4];
  bool operator==(const InformationBits&) const = default;
};
struct InformationBitsHash {
  size_t operator()(const InformationBits& bits) const {
    uint64_t h = 0x9E3779B97F4A7C15ull;
    for (const uint64_t w : bits.word) h = (h ^ w) * 0xBF58476D1CE4E5B9ull;
    return static_cast<size_t>(h ^ (h >> 31));
  }
};
InformationBits BitsOf(const core::Observation& observation) {
  static_assert(sizeof(InformationBits) == format::kInformationSize);
  InformationBits bits;
  std::memcpy(bits.word, observation.information.data(), sizeof(bits.word));
  return bits;
}

// Streams header, blocks and footer into `file`.
class ChunkEncoder {
 public:
  ChunkEncoder(const core::ObservationChunk& chunk, const ChunkWriteOptions& options)
      : chunk_(chunk), options_(options) {}

  Status Write(WritableFile* file) {
    const uint32_t flags =
        options_.compression == ChunkCompression::kZstd ? format::kFlagZstd : 0u;
    const std::string header = EncodeHeader(chunk_, options_.format_version, flags);
    GS_RETURN_IF_ERROR(file->Append(header));
    // "Footer": chain_crc covers the stored header CRC, then each block's.
    uint32_t chain = crc32c::Value(header.data() + format::kHeaderCrcOffset, 4);

    const int64_t num_features = chunk_.num_features();
    uint32_t num_blocks = 0;
    for (int64_t begin = 0; begin < num_features;) {
      const int64_t end = BlockEnd(begin);
      uint32_t crc = 0;
      GS_RETURN_IF_ERROR(WriteBlock(begin, end, file, &crc));
      char stored[4];
      for (int i = 0; i < 4; ++i) stored[i] = static_cast<char>((crc >> (8 * i)) & 0xFFu);
      chain = crc32c::Extend(chain, stored, 4);
      ++num_blocks;
      begin = end;
    }

    std::string footer;
    format::PutFixed64(&footer, static_cast<uint64_t>(num_features));
    format::PutFixed64(&footer, static_cast<uint64_t>(chunk_.observations.size()));
    format::PutFixed32(&footer, num_blocks);
    format::PutFixed32(&footer, crc32c::Mask(chain));
    GS_CHECK(footer.size() == format::kFooterSize);
    EncodeRecordHeader(format::kFooter, footer, &frame_);
    GS_RETURN_IF_ERROR(file->Append(frame_));
    return file->Append(footer);
  }

 private:
  int64_t Begin(int64_t slot) const {
    return chunk_.feature_begin.empty() ? 0 : chunk_.feature_begin[static_cast<size_t>(slot)];
  }

  // One past the last slot of the block starting at `begin`: grow while the
  // block stays within target_record_bytes, but take at least one feature.
  int64_t BlockEnd(int64_t begin) const {
    const int64_t num_features = chunk_.num_features();
    int64_t end = begin + 1;
    while (end < num_features &&
           BlockBytes(options_.format_version, static_cast<size_t>(end + 1 - begin),
                      Begin(end + 1) - Begin(begin)) <=
               static_cast<size_t>(options_.target_record_bytes)) {
      ++end;
    }
    return end;
  }

  Status WriteBlock(int64_t begin, int64_t end, WritableFile* file, uint32_t* crc) {
    const int64_t first_observation = Begin(begin);
    const int64_t last_observation = Begin(end);
    raw_.clear();
    raw_.reserve(BlockBytes(options_.format_version, static_cast<size_t>(end - begin),
                            last_observation - first_observation));
    format::PutFixed64(&raw_, static_cast<uint64_t>(begin));
    format::PutFixed64(&raw_, static_cast<uint64_t>(first_observation));
    format::PutFixed32(&raw_, static_cast<uint32_t>(end - begin));
    for (int64_t k = begin; k < end; ++k) {
      format::PutFixed32(&raw_, static_cast<uint32_t>(chunk_.features[static_cast<size_t>(k)]));
      format::PutFixed32(&raw_, static_cast<uint32_t>(Begin(k + 1) - Begin(k)));
    }
    if (options_.format_version >= format::kColumnarVersion) {
      AppendColumns(first_observation, last_observation);
    } else {
      for (int64_t o = first_observation; o < last_observation; ++o) {
        format::PutObservation(&raw_, chunk_.observations[static_cast<size_t>(o)]);
      }
    }
    GS_CHECK(raw_.size() <= format::kMaxRecordLength);  // ValidateObservationChunk bounds it

    std::string_view payload = raw_;
    uint8_t type = format::kFeatureBlock;
    if (options_.compression == ChunkCompression::kZstd) {
      compressed_.resize(4 + ZSTD_compressBound(raw_.size()));
      if (context_ == nullptr) context_.reset(ZSTD_createCCtx());
      if (context_ == nullptr) return Status::IOError("zstd: cannot allocate a compression context");
      const size_t size = ZSTD_compressCCtx(context_.get(), compressed_.data() + 4,
                                            compressed_.size() - 4, raw_.data(), raw_.size(),
                                            options_.zstd_level);
      if (ZSTD_isError(size)) {
        return Status::IOError(std::string("zstd compression of feature slots ") +
                               std::to_string(begin) + ".." + std::to_string(end - 1) +
                               " failed: " + ZSTD_getErrorName(size));
      }
      // Stored compressed only when it saves space (LevelDB keeps a block raw
      // unless compression saves 12.5%; any saving is enough here).
      if (4 + size < raw_.size()) {
        const auto length = static_cast<uint32_t>(raw_.size());
        for (int i = 0; i < 4; ++i) compressed_[i] = static_cast<char>((length >> (8 * i)) & 0xFFu);
        payload = std::string_view(compressed_.data(), 4 + size);
        type = format::kFeatureBlock | format::kCompressedBit;
      }
    }
    *crc = EncodeRecordHeader(type, payload, &frame_);
    GS_RETURN_IF_ERROR(file->Append(frame_));
    return file->Append(payload);
  }

  // Version 2: the information table in order of first use, and each
  // observation's entry; one entry per observation when the table would not
  // be smaller than that (informations mostly distinct).
  void BuildInformationTable(const core::Observation* observations, size_t n) {
    table_.clear();
    lookup_.clear();
    indices_.resize(n);
    bool overflow = false;
    uint32_t last = 0;
    for (size_t i = 0; i < n && !overflow; ++i) {
      const InformationBits bits = BitsOf(observations[i]);
      // One sensor's observations share one matrix: compare with the last
      // entry used before hashing.
      if (!table_.empty() && bits == table_[last]) {
        indices_[i] = last;
        continue;
      }
      const auto [it, inserted] = lookup_.try_emplace(bits, static_cast<uint32_t>(table_.size()));
      if (inserted) {
        table_.push_back(bits);
        overflow = table_.size() > format::kMaxIndexedInformations;
      }
      last = it->second;
      indices_[i] = last;
    }
    const size_t entries = table_.size();
    const int width = overflow ? -1 : format::InformationIndexWidth(entries, n);
    if (width < 0 || (entries != n && format::kInformationSize * entries +
                                              static_cast<size_t>(width) * n >=
                                          format::kInformationSize * n)) {
      table_.clear();
      for (size_t i = 0; i < n; ++i) table_.push_back(BitsOf(observations[i]));
    }
  }

  // "Feature block", version 2: the table, then one column per field.
  void AppendColumns(int64_t first_observation, int64_t last_observation) {
    const auto n = static_cast<size_t>(last_observation - first_observation);
    const core::Observation* o = chunk_.observations.data() + first_observation;
    BuildInformationTable(o, n);
    const size_t entries = table_.size();
    const int width = format::InformationIndexWidth(entries, n);
    GS_CHECK(width >= 0);
    const size_t at = raw_.size();
    raw_.resize(at + format::kInformationCountSize + format::kInformationSize * entries +
                (format::kColumnsSize + static_cast<size_t>(width)) * n);
    char* p = format::EncodeFixed32(raw_.data() + at, static_cast<uint32_t>(entries));
    for (const InformationBits& bits : table_) {
      for (const uint64_t w : bits.word) p = format::EncodeFixed64(p, w);
    }
    uint32_t previous = 0;
    for (size_t i = 0; i < n; ++i) {
      const auto pose = static_cast<uint32_t>(o[i].pose);
      p = format::EncodeFixed32(p, pose - previous);  // wraps: exact for every i32
      previous = pose;
    }
    for (size_t i = 0; i < n; ++i) *p++ = static_cast<char>(o[i].kind);
    for (size_t i = 0; i < n; ++i) p = format::EncodeFixed64(p, std::bit_cast<uint64_t>(o[i].z[0]));
    for (size_t i = 0; i < n; ++i) p = format::EncodeFixed64(p, std::bit_cast<uint64_t>(o[i].z[1]));
    if (width == 1) {
      for (size_t i = 0; i < n; ++i) *p++ = static_cast<char>(indices_[i]);
    } else if (width == 2) {
      for (size_t i = 0; i < n; ++i) {
        *p++ = static_cast<char>(indices_[i] & 0xFFu);
        *p++ = static_cast<char>(indices_[i] >> 8);
      }
    }
    previous = 0;
    for (size_t i = 0; i < n; ++i) {
      const auto line = static_cast<uint32_t>(o[i].line);
      p = format::EncodeFixed32(p, line - previous);
      previous = line;
    }
    GS_CHECK(p == raw_.data() + raw_.size());
  }

  const core::ObservationChunk& chunk_;
  const ChunkWriteOptions& options_;
  std::vector<InformationBits> table_;  // version 2: the current block's table
  std::unordered_map<InformationBits, uint32_t, InformationBitsHash> lookup_;
  std::vector<uint32_t> indices_;       // table entry of each observation
  std::string raw_;         // the current block, uncompressed
  std::string compressed_;  // its zstd form, behind a 4-byte length
  std::string frame_;       // the current record header
  struct FreeContext {
    void operator()(ZSTD_CCtx* context) const { ZSTD_freeCCtx(context); }
  };
  std::unique_ptr<ZSTD_CCtx, FreeContext> context_;  // reused across blocks
};

}  // namespace

Status ChunkWriteOptions::Validate() const {
  if (compression != ChunkCompression::kNone && compression != ChunkCompression::kZstd) {
    return Status::InvalidArgument("ChunkWriteOptions::compression is " +
                                   std::to_string(static_cast<int>(compression)) +
                                   ", expected kNone (0) or kZstd (1)");
  }
  if (compression == ChunkCompression::kZstd &&
      (zstd_level < ZSTD_minCLevel() || zstd_level > ZSTD_maxCLevel())) {
    return Status::InvalidArgument("ChunkWriteOptions::zstd_level is " +
                                   std::to_string(zstd_level) + ", expected a level in [" +
                                   std::to_string(ZSTD_minCLevel()) + ", " +
                                   std::to_string(ZSTD_maxCLevel()) + "]");
  }
  if (format_version < 1 || format_version > chunk_format::kFormatVersion) {
    return Status::InvalidArgument("ChunkWriteOptions::format_version is " +
                                   std::to_string(format_version) + ", expected 1 to " +
                                   std::to_string(chunk_format::kFormatVersion));
  }
  if (target_record_bytes < 1 ||
      target_record_bytes > static_cast<int64_t>(chunk_format::kMaxRecordLength)) {
    return Status::InvalidArgument("ChunkWriteOptions::target_record_bytes is " +
                                   std::to_string(target_record_bytes) + ", expected [1, " +
                                   std::to_string(chunk_format::kMaxRecordLength) + "]");
  }
  return Status::Ok();
}

Status ValidateObservationChunk(const core::ObservationChunk& chunk) {
  const size_t num_features = chunk.features.size();
  const auto num_observations = static_cast<int64_t>(chunk.observations.size());
  if (chunk.index < 0) {
    return Status::InvalidArgument("chunk index is " + std::to_string(chunk.index) +
                                   ", expected >= 0");
  }
  if (chunk.feature_begin.empty()) {
    if (num_features == 0 && num_observations == 0) return Status::Ok();
    return Status::InvalidArgument("feature_begin is empty, expected " +
                                   std::to_string(num_features + 1) + " entries (features + 1)");
  }
  if (chunk.feature_begin.size() != num_features + 1) {
    return Status::InvalidArgument("feature_begin has " +
                                   std::to_string(chunk.feature_begin.size()) +
                                   " entries, expected " + std::to_string(num_features + 1) +
                                   " (features + 1)");
  }
  if (chunk.feature_begin.front() != 0) {
    return Status::InvalidArgument("feature_begin[0] is " +
                                   std::to_string(chunk.feature_begin.front()) + ", expected 0");
  }
  if (chunk.feature_begin.back() != num_observations) {
    return Status::InvalidArgument("feature_begin[" + std::to_string(num_features) + "] is " +
                                   std::to_string(chunk.feature_begin.back()) + ", expected " +
                                   std::to_string(num_observations) +
                                   " (the number of observations)");
  }
  for (size_t k = 0; k < num_features; ++k) {
    const int32_t feature = chunk.features[k];
    const int64_t begin = chunk.feature_begin[k];
    const int64_t end = chunk.feature_begin[k + 1];
    if (feature < 0) {
      return Status::InvalidArgument(SlotName(static_cast<int64_t>(k), feature) +
                                     ": feature index is negative");
    }
    if (k > 0 && feature <= chunk.features[k - 1]) {
      return Status::InvalidArgument(SlotName(static_cast<int64_t>(k), feature) +
                                     ": expected a feature above " +
                                     std::to_string(chunk.features[k - 1]) +
                                     " (features must be strictly ascending)");
    }
    if (end < begin) {
      return Status::InvalidArgument(SlotName(static_cast<int64_t>(k), feature) +
                                     ": feature_begin decreases from " + std::to_string(begin) +
                                     " to " + std::to_string(end));
    }
    // Version 1's size, the larger: a chunk either version can hold.
    if (BlockBytes(1, 1, end - begin) > chunk_format::kMaxRecordLength) {
      return Status::InvalidArgument(
          SlotName(static_cast<int64_t>(k), feature) + ": " + std::to_string(end - begin) +
          " observations exceed the largest feature block (" +
          std::to_string(chunk_format::kMaxRecordLength) + " bytes)");
    }
    for (int64_t o = begin; o < end; ++o) {
      // The predicate first: the message is built only for a bad observation.
      if (chunk_format::IsValidObservation(chunk.observations[static_cast<size_t>(o)], feature))
        continue;
      const std::string problem = chunk_format::DescribeInvalidObservation(
          chunk.observations[static_cast<size_t>(o)], feature);
      if (!problem.empty()) {
        return Status::InvalidArgument("observation " + std::to_string(o) + " (feature slot " +
                                       std::to_string(k) + "): " + problem);
      }
    }
  }
  return Status::Ok();
}

Status WriteObservationChunk(Env* env, const std::string& path,
                             const core::ObservationChunk& chunk,
                             const ChunkWriteOptions& options) {
  GS_CHECK(env != nullptr);
  // Rule 9: reject bad input before the first byte reaches the disk.
  GS_RETURN_IF_ERROR(options.Validate().WithContext("writing " + path));
  GS_RETURN_IF_ERROR(ValidateObservationChunk(chunk).WithContext(
      "writing " + path + ": chunk " + std::to_string(chunk.index)));
  ChunkEncoder encoder(chunk, options);
  return WriteFileAtomically(env, path,
                             [&encoder](WritableFile* file) { return encoder.Write(file); });
}

namespace {

// Collects what ChunkEncoder appends (EncodeObservationChunk).
class StringFile final : public WritableFile {
 public:
  explicit StringFile(std::string* out) : out_(out) {}
  Status Append(std::string_view data) override {
    out_->append(data);
    return Status::Ok();
  }
  Status Sync() override { return Status::Ok(); }
  Status Close() override { return Status::Ok(); }

 private:
  std::string* out_;
};

}  // namespace

Status EncodeObservationChunk(const core::ObservationChunk& chunk, const ChunkWriteOptions& options,
                              std::string* out) {
  GS_CHECK(out != nullptr);
  out->clear();
  GS_RETURN_IF_ERROR(options.Validate());
  GS_RETURN_IF_ERROR(
      ValidateObservationChunk(chunk).WithContext("chunk " + std::to_string(chunk.index)));
  ChunkEncoder encoder(chunk, options);
  StringFile file(out);
  return encoder.Write(&file);
}

}  // namespace graphslam::storage
