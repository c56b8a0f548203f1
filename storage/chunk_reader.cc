// Reader of docs/formats/observation_chunk.md; section names below refer to it.
#include "storage/chunk_reader.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <memory>
#include <utility>
#include <vector>

#include "core/logging.h"
#include "storage/chunk_format.h"
#include "storage/crc32c.h"

namespace graphslam::storage {
namespace {

namespace format = chunk_format;

std::string Hex32(uint32_t value) {
  char buffer[16];
  std::snprintf(buffer, sizeof(buffer), "0x%08" PRIx32, value);
  return buffer;
}
std::string Hex64(uint64_t value) {
  char buffer[24];
  std::snprintf(buffer, sizeof(buffer), "0x%016" PRIx64, value);
  return buffer;
}
std::string CrcMismatch(uint32_t expected, uint32_t actual) {
  return "crc mismatch (expected " + Hex32(expected) + ", got " + Hex32(actual) + ")";
}

Status ReadWholeFile(const std::string& path, std::string* contents) {
  const auto error = [&path](const char* operation, int error_number) {
    const std::string message = path + ": " + operation + ": " + std::strerror(error_number);
    return error_number == ENOENT ? Status::NotFound(message) : Status::IOError(message);
  };
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return error("open", errno);
  struct stat info;
  if (::fstat(fd, &info) != 0) {
    const int saved = errno;
    ::close(fd);
    return error("fstat", saved);
  }
  contents->resize(static_cast<size_t>(info.st_size));
  size_t done = 0;
  while (done < contents->size()) {
    const ssize_t got = ::read(fd, contents->data() + done, contents->size() - done);
    if (got < 0 && errno == EINTR) continue;
    if (got < 0) {
      const int saved = errno;
      ::close(fd);
      return error("read", saved);
    }
    if (got == 0) break;  // the file shrank while we read: the checks below see it
    done += static_cast<size_t>(got);
  }
  contents->resize(done);
  ::close(fd);
  return Status::Ok();
}

class ChunkParser {
 public:
  ChunkParser(const std::string& path, const std::string& data, const ChunkReadOptions& options)
      : path_(path), data_(data), options_(options) {}

  Status Parse(core::ObservationChunk* result) {
    result_ = result;
    GS_RETURN_IF_ERROR(ParseHeader());
    result_->index = index_;
    result_->feature_begin.push_back(0);
    result_->features.reserve(static_cast<size_t>(std::min<int64_t>(num_features_, kMaxReserve)));
    result_->observations.reserve(
        static_cast<size_t>(std::min<int64_t>(num_observations_, kMaxReserve)));
    return ParseRecords();
  }

 private:
  // A corrupt count must not make us reserve gigabytes; vectors grow past it.
  static constexpr int64_t kMaxReserve = int64_t{1} << 20;

  // "Header". Errors here are fatal in both modes.
  Status ParseHeader() {
    const size_t size = data_.size();
    if (size >= 8 && format::DecodeFixed64(data_.data()) != format::kMagic) {
      return Status::Corruption(path_ + ": header at byte 0: bad magic number (expected " +
                                Hex64(format::kMagic) + ", got " +
                                Hex64(format::DecodeFixed64(data_.data())) +
                                "): not an observation chunk");
    }
    if (size < format::kHeaderSize) {
      return Status::Corruption(path_ + ": truncated at byte " + std::to_string(size) +
                                ": the file is shorter than the " +
                                std::to_string(format::kHeaderSize) + "-byte header");
    }
    const char* p = data_.data();
    const uint32_t version = format::DecodeFixed32(p + 8);
    // A newer version may have another header layout: say so before its CRC.
    if (version > format::kFormatVersion) {
      return Status::NotSupported(path_ + ": header at byte 8: format version " +
                                  std::to_string(version) + " is newer than this reader (" +
                                  std::to_string(format::kFormatVersion) + ")");
    }
    const uint32_t stored = crc32c::Unmask(format::DecodeFixed32(p + format::kHeaderCrcOffset));
    const uint32_t actual = crc32c::Value(p, format::kHeaderCrcOffset);
    if (stored != actual) {
      return Status::Corruption(path_ + ": header at byte 0: " + CrcMismatch(stored, actual));
    }
    chain_ = crc32c::Value(p + format::kHeaderCrcOffset, 4);  // "Footer": the chain starts here
    if (version == 0) {
      return Status::Corruption(path_ + ": header at byte 8: format version 0 is invalid (expected 1 to " +
                                std::to_string(format::kFormatVersion) + ")");
    }
    version_ = version;
    flags_ = format::DecodeFixed32(p + 12);
    if ((flags_ & ~format::kKnownFlags) != 0) {
      return Status::NotSupported(path_ + ": header at byte 12: unknown flags " + Hex32(flags_) +
                                  " (this reader knows " + Hex32(format::kKnownFlags) + ")");
    }
    index_ = static_cast<int64_t>(format::DecodeFixed64(p + 16));
    num_features_ = static_cast<int64_t>(format::DecodeFixed64(p + 24));
    num_observations_ = static_cast<int64_t>(format::DecodeFixed64(p + 32));
    const uint32_t reserved = format::DecodeFixed32(p + 40);
    if (index_ < 0 || num_features_ < 0 || num_observations_ < 0 || reserved != 0) {
      return Status::Corruption(
          path_ + ": header at byte 16: invalid fields (chunk index " + std::to_string(index_) +
          ", " + std::to_string(num_features_) + " features, " +
          std::to_string(num_observations_) + " observations, reserved " + Hex32(reserved) +
          "; expected non-negative counts and reserved 0)");
    }
    return Status::Ok();
  }

  std::string Where(int64_t record, size_t offset) const {
    return path_ + ": record " + std::to_string(record) + " at byte " + std::to_string(offset) +
           ": ";
  }

  // Paranoid: returns `status` (stop). Otherwise reports and returns OK.
  Status Drop(size_t bytes, const Status& status) {
    if (options_.paranoid) return status;
    dropped_any_ = true;
    if (options_.reporter != nullptr) {
      options_.reporter->Corruption(static_cast<int64_t>(bytes), status);
    } else {
      GS_LOG(WARNING, "dropped %zu bytes: %s", bytes, status.ToString().c_str());
    }
    return Status::Ok();
  }

  // "Records" and "Footer".
  Status ParseRecords() {
    const size_t size = data_.size();
    size_t position = format::kHeaderSize;
    for (int64_t record = 0;; ++record) {
      const size_t left = size - position;
      if (left == 0) {
        // Atomic writes never leave this; the file was cut at a record boundary.
        // After a drop the footer itself may have been the damaged record.
        const std::string what = dropped_any_ ? ": the file ends without a valid footer after "
                                              : ": no footer after ";
        return Drop(0, Status::Corruption(
                           path_ + (dropped_any_ ? ": at byte " : ": truncated at byte ") +
                           std::to_string(size) + what + std::to_string(record) +
                           " records (the header promises " + std::to_string(num_features_) +
                           " features and " + std::to_string(num_observations_) +
                           " observations; read " + std::to_string(result_->features.size()) +
                           " and " + std::to_string(result_->observations.size()) + ")"));
      }
      if (left < format::kRecordHeaderSize) {
        return Drop(left, Status::Corruption(Where(record, position) +
                                             "truncated record header (" +
                                             std::to_string(format::kRecordHeaderSize) +
                                             " bytes expected, " + std::to_string(left) +
                                             " left in the file)"));
      }
      const char* p = data_.data() + position;
      const uint32_t length = format::DecodeFixed32(p);
      const auto type = static_cast<uint8_t>(p[4]);
      if (length > left - format::kRecordHeaderSize) {
        return Drop(left, Status::Corruption(
                              Where(record, position) + "length " + std::to_string(length) +
                              " exceeds the " + std::to_string(left - format::kRecordHeaderSize) +
                              " bytes left in the file after the record header (bad length or "
                              "truncated file)"));
      }
      const size_t record_bytes = format::kRecordHeaderSize + length;
      const std::string_view payload(p + format::kRecordHeaderSize, length);
      const uint32_t stored = crc32c::Unmask(format::DecodeFixed32(p + 5));
      const uint32_t actual = crc32c::Extend(crc32c::Value(p + 4, 1), payload.data(), length);
      if (stored != actual) {
        GS_RETURN_IF_ERROR(Drop(record_bytes, Status::Corruption(Where(record, position) +
                                                                 CrcMismatch(stored, actual))));
        position += record_bytes;
        continue;
      }
      if (type == format::kFooter) {
        return ParseFooter(record, position, payload);
      }
      Status status;
      if ((type & ~format::kCompressedBit) != format::kFeatureBlock) {
        status = Status::Corruption(Where(record, position) + "unknown record type " +
                                    Hex32(type) + " (expected 0x01, 0x81 or 0x02)");
      } else {
        status = ParseBlock(record, position, type, payload);
        if (status.ok()) {
          chain_ = crc32c::Extend(chain_, p + 5, 4);
          ++blocks_;
        }
      }
      if (!status.ok()) GS_RETURN_IF_ERROR(Drop(record_bytes, status));
      position += record_bytes;
    }
  }

  Status ParseFooter(int64_t record, size_t position, std::string_view payload) {
    const std::string where = Where(record, position) + "footer: ";
    if (payload.size() != format::kFooterSize) {
      return Status::Corruption(where + "payload is " + std::to_string(payload.size()) +
                                " bytes, expected " + std::to_string(format::kFooterSize));
    }
    const auto features = static_cast<int64_t>(format::DecodeFixed64(payload.data()));
    const auto observations = static_cast<int64_t>(format::DecodeFixed64(payload.data() + 8));
    const uint32_t blocks = format::DecodeFixed32(payload.data() + 16);
    const uint32_t chain = crc32c::Unmask(format::DecodeFixed32(payload.data() + 20));
    if (features != num_features_ || observations != num_observations_) {
      return Status::Corruption(where + std::to_string(features) + " features and " +
                                std::to_string(observations) + " observations, expected " +
                                std::to_string(num_features_) + " and " +
                                std::to_string(num_observations_) + " (the header's counts)");
    }
    // After a drop the totals cannot match; the drop was reported already.
    if (!dropped_any_) {
      const auto read_features = static_cast<int64_t>(result_->features.size());
      const auto read_observations = static_cast<int64_t>(result_->observations.size());
      if (blocks != blocks_ || read_features != features || read_observations != observations) {
        return Status::Corruption(where + "promises " + std::to_string(blocks) + " blocks, " +
                                  std::to_string(features) + " features and " +
                                  std::to_string(observations) + " observations; read " +
                                  std::to_string(blocks_) + ", " + std::to_string(read_features) +
                                  " and " + std::to_string(read_observations));
      }
      if (chain != chain_) {
        return Status::Corruption(where + "chained " + CrcMismatch(chain, chain_) +
                                  ": records are missing, repeated or out of order");
      }
    }
    const size_t end = position + format::kRecordHeaderSize + format::kFooterSize;
    if (end != data_.size()) {
      const size_t trailing = data_.size() - end;
      return Drop(trailing, Status::Corruption(path_ + ": " + std::to_string(trailing) +
                                               " bytes after the footer that ends at byte " +
                                               std::to_string(end) +
                                               " (expected the end of the file)"));
    }
    return Status::Ok();
  }

  // "Feature blocks". On error the result is rolled back to before the block.
  Status ParseBlock(int64_t record, size_t position, uint8_t type, std::string_view payload) {
    const std::string where = Where(record, position);
    if ((type & format::kCompressedBit) != 0) {
      if ((flags_ & format::kFlagZstd) == 0) {
        return Status::Corruption(where + "compressed record in a file whose header (flags " +
                                  Hex32(flags_) + ") does not allow compression");
      }
      if (payload.size() < 4) {
        return Status::Corruption(where + "compressed payload of " +
                                  std::to_string(payload.size()) +
                                  " bytes is shorter than its 4-byte length prefix");
      }
      const uint32_t length = format::DecodeFixed32(payload.data());
      if (length > format::kMaxRecordLength) {
        return Status::Corruption(where + "uncompressed length " + std::to_string(length) +
                                  " exceeds the largest block (" +
                                  std::to_string(format::kMaxRecordLength) + " bytes)");
      }
      // Not zero-filled first (std::string::resize would write each byte of
      // a whole chunk once more): zstd writes all `length` bytes or fails.
      if (uncompressed_capacity_ < length) {
        uncompressed_ = std::make_unique_for_overwrite<char[]>(length);
        uncompressed_capacity_ = length;
      }
      const size_t got = ZSTD_decompress(uncompressed_.get(), length, payload.data() + 4,
                                         payload.size() - 4);
      if (ZSTD_isError(got)) {
        return Status::Corruption(where + "zstd: " + ZSTD_getErrorName(got));
      }
      if (got != length) {
        return Status::Corruption(where + "zstd frame holds " + std::to_string(got) +
                                  " bytes, expected " + std::to_string(length));
      }
      payload = std::string_view(uncompressed_.get(), length);
    }
    const size_t features_before = result_->features.size();
    const size_t observations_before = result_->observations.size();
    Status status = DecodeBlock(where, payload);
    if (!status.ok()) {
      result_->features.resize(features_before);
      result_->feature_begin.resize(features_before + 1);
      result_->observations.resize(observations_before);
    }
    return status;
  }

  Status DecodeBlock(const std::string& where, std::string_view payload) {
    if (payload.size() < format::kBlockHeaderSize) {
      return Status::Corruption(where + "feature block of " + std::to_string(payload.size()) +
                                " bytes is shorter than its " +
                                std::to_string(format::kBlockHeaderSize) + "-byte header");
    }
    const char* p = payload.data();
    const auto first_slot = static_cast<int64_t>(format::DecodeFixed64(p));
    const auto first_observation = static_cast<int64_t>(format::DecodeFixed64(p + 8));
    const uint32_t count = format::DecodeFixed32(p + 16);
    // Continuity: exactly where the previous block ended, unless a dropped
    // record lies between (then anything later is fine).
    const bool continuous = first_slot == next_slot_ && first_observation == next_observation_;
    const bool after_gap = dropped_any_ && first_slot >= next_slot_ &&
                           first_observation >= next_observation_;
    if (!continuous && !after_gap) {
      return Status::Corruption(where + "block starts at feature slot " +
                                std::to_string(first_slot) + " and observation " +
                                std::to_string(first_observation) + ", expected " +
                                std::to_string(next_slot_) + " and " +
                                std::to_string(next_observation_) +
                                " (a record is missing, repeated or out of order)");
    }
    const size_t table_end = format::kBlockHeaderSize + format::kFeatureEntrySize * count;
    if (count == 0 || table_end > payload.size()) {
      return Status::Corruption(where + "feature block of " + std::to_string(payload.size()) +
                                " bytes cannot hold its " + std::to_string(count) +
                                " features (expected 1 or more, " +
                                std::to_string(format::kFeatureEntrySize) + " bytes each)");
    }
    uint64_t block_observations = 0;
    for (uint32_t k = 0; k < count; ++k) {
      block_observations += format::DecodeFixed32(p + format::kBlockHeaderSize + 8 * k + 4);
    }
    if (version_ < format::kColumnarVersion) {
      const uint64_t expected_size = table_end + format::kObservationSize * block_observations;
      if (expected_size != payload.size()) return SizeMismatch(where, payload.size(), expected_size,
                                                               count, block_observations);
      RowDecoder rows{p + table_end};
      return DecodeFeatures(where, p, first_slot, first_observation, count, rows);
    }
    // Version 2: the information table, then the columns.
    if (table_end + format::kInformationCountSize > payload.size()) {
      return SizeMismatch(where, payload.size(), table_end + format::kInformationCountSize,
                          count, block_observations);
    }
    const uint32_t entries = format::DecodeFixed32(p + table_end);
    const int width = format::InformationIndexWidth(entries, block_observations);
    if (width < 0) {
      return Status::Corruption(where + "information table of " + std::to_string(entries) +
                                " entries for " + std::to_string(block_observations) +
                                " observations (expected 1 entry, one per observation, or at "
                                "most " + std::to_string(format::kMaxIndexedInformations) +
                                " and no more than the observations)");
    }
    const uint64_t table_at = table_end + format::kInformationCountSize;
    const uint64_t columns_at = table_at + uint64_t{format::kInformationSize} * entries;
    const uint64_t expected_size =
        columns_at + (format::kColumnsSize + static_cast<uint64_t>(width)) * block_observations;
    if (expected_size != payload.size()) {
      return SizeMismatch(where, payload.size(), expected_size, count, block_observations);
    }
    informations_.resize(entries);
    for (uint32_t e = 0; e < entries; ++e) {
      for (int j = 0; j < 4; ++j) {
        informations_[e].data()[j] =
            format::DecodeDouble(p + table_at + format::kInformationSize * e + 8 * j);
      }
    }
    const char* columns = p + columns_at;
    const size_t n = block_observations;
    ColumnDecoder decoder;
    decoder.poses = columns;
    decoder.kinds = decoder.poses + 4 * n;
    decoder.z0 = decoder.kinds + n;
    decoder.z1 = decoder.z0 + 8 * n;
    decoder.indices = decoder.z1 + 8 * n;
    decoder.lines = decoder.indices + static_cast<size_t>(width) * n;
    decoder.informations = informations_.data();
    decoder.entries = entries;
    decoder.width = width;
    decoder.one_each = entries == n;
    return DecodeFeatures(where, p, first_slot, first_observation, count, decoder);
  }

  static Status SizeMismatch(const std::string& where, size_t size, uint64_t expected,
                             uint32_t count, uint64_t observations) {
    return Status::Corruption(where + "feature block is " + std::to_string(size) +
                              " bytes, expected " + std::to_string(expected) + " for " +
                              std::to_string(count) + " features and " +
                              std::to_string(observations) + " observations");
  }

  // Version 1: one 61-byte record per observation.
  struct RowDecoder {
    const char* next;
    // Always true: a version 1 record has no field beyond
    // DescribeInvalidObservation's rules, so Problem is never asked.
    bool Decode(size_t, core::Observation* observation) {
      format::DecodeObservation(next, observation);
      next += format::kObservationSize;
      return true;
    }
    std::string Problem(size_t) const { return ""; }
  };

  // Version 2: observation i of the block from its columns; the deltas run
  // over the whole block, so observations are decoded in order.
  struct ColumnDecoder {
    const char* poses;
    const char* kinds;
    const char* z0;
    const char* z1;
    const char* indices;
    const char* lines;
    const Eigen::Matrix2d* informations;
    uint32_t entries = 0;
    int width = 0;
    bool one_each = false;
    uint32_t pose = 0;
    uint32_t line = 0;
    // False when observation i's information index is out of the table
    // (Problem says so); the other fields are decoded either way.
    bool Decode(size_t i, core::Observation* observation) {
      pose += format::DecodeFixed32(poses + 4 * i);
      line += format::DecodeFixed32(lines + 4 * i);
      observation->pose = static_cast<int32_t>(pose);
      observation->line = static_cast<int32_t>(line);
      observation->kind = static_cast<core::ObservationKind>(static_cast<uint8_t>(kinds[i]));
      observation->z[0] = format::DecodeDouble(z0 + 8 * i);
      observation->z[1] = format::DecodeDouble(z1 + 8 * i);
      const uint32_t index = Index(i);
      if (index >= entries) return false;
      observation->information = informations[index];
      return true;
    }
    uint32_t Index(size_t i) const {
      if (width == 1) return static_cast<uint8_t>(indices[i]);
      if (width == 2) {
        return static_cast<uint32_t>(static_cast<uint8_t>(indices[2 * i])) |
               (static_cast<uint32_t>(static_cast<uint8_t>(indices[2 * i + 1])) << 8);
      }
      return one_each ? static_cast<uint32_t>(i) : 0u;
    }
    std::string Problem(size_t i) const {
      return "information index " + std::to_string(Index(i)) + " is not below the " +
             std::to_string(entries) + " entries of the block's table";
    }
  };

  // The features of a block whose sizes were checked, their observations
  // taken from `decoder` in order.
  template <class Decoder>
  Status DecodeFeatures(const std::string& where, const char* p, int64_t first_slot,
                        int64_t first_observation, uint32_t count, Decoder& decoder) {
    int64_t observation = first_observation;  // numbering of the file, for messages
    size_t in_block = 0;
    core::Observation decoded;
    for (uint32_t k = 0; k < count; ++k) {
      const char* entry = p + format::kBlockHeaderSize + format::kFeatureEntrySize * k;
      const auto feature = static_cast<int32_t>(format::DecodeFixed32(entry));
      const uint32_t feature_observations = format::DecodeFixed32(entry + 4);
      const int64_t slot = first_slot + k;
      // Built only for a message: two strings per feature were a visible part
      // of a streaming pass.
      const auto slot_name = [&] {
        return "feature slot " + std::to_string(slot) + " (feature " + std::to_string(feature) +
               ")";
      };
      if (feature < 0) return Status::Corruption(where + slot_name() + ": negative feature index");
      if (!result_->features.empty() && feature <= result_->features.back()) {
        return Status::Corruption(where + slot_name() + ": expected a feature above " +
                                  std::to_string(result_->features.back()) +
                                  " (features must be strictly ascending)");
      }
      decoded.feature = feature;  // version 2 does not repeat it; version 1 overwrites it
      for (uint32_t i = 0; i < feature_observations; ++i, ++observation, ++in_block) {
        const bool indexed = decoder.Decode(in_block, &decoded);
        if (!indexed || !format::IsValidObservation(decoded, feature)) {
          return Status::Corruption(where + "observation " + std::to_string(observation) +
                                    " (" + slot_name() + "): " +
                                    (indexed ? format::DescribeInvalidObservation(decoded, feature)
                                             : decoder.Problem(in_block)));
        }
        result_->observations.push_back(decoded);
      }
      result_->features.push_back(feature);
      result_->feature_begin.push_back(static_cast<int64_t>(result_->observations.size()));
    }
    next_slot_ = first_slot + count;
    next_observation_ = observation;
    return Status::Ok();
  }

  const std::string& path_;
  const std::string& data_;
  const ChunkReadOptions& options_;
  core::ObservationChunk* result_ = nullptr;

  uint32_t version_ = 0;
  uint32_t flags_ = 0;
  int64_t index_ = 0;
  int64_t num_features_ = 0;
  int64_t num_observations_ = 0;

  int64_t next_slot_ = 0;         // where the next block must start, in the file's numbering
  int64_t next_observation_ = 0;
  uint32_t blocks_ = 0;           // feature blocks accepted
  uint32_t chain_ = 0;            // CRC32C over the header's and accepted blocks' stored CRCs
  bool dropped_any_ = false;
  std::vector<Eigen::Matrix2d> informations_;  // version 2: the block's table
  std::unique_ptr<char[]> uncompressed_;  // the current block, decompressed
  size_t uncompressed_capacity_ = 0;
};

}  // namespace

Status ReadObservationChunk(const std::string& path, core::ObservationChunk* chunk,
                            const ChunkReadOptions& options) {
  GS_CHECK(chunk != nullptr);
  std::string data;
  GS_RETURN_IF_ERROR(ReadWholeFile(path, &data));
  core::ObservationChunk result;
  ChunkParser parser(path, data, options);
  GS_RETURN_IF_ERROR(parser.Parse(&result));
  *chunk = std::move(result);
  return Status::Ok();
}

}  // namespace graphslam::storage
