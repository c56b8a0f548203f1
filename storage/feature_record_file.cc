#include "storage/feature_record_file.h"

#include <cerrno>
#include <cstring>

#include "storage/chunk_format.h"
#include "storage/crc32c.h"

namespace graphslam::storage::feature_records {

using chunk_format::DecodeFixed32;
using chunk_format::DecodeFixed64;
using chunk_format::PutFixed32;
using chunk_format::PutFixed64;

std::string EncodeHeader(uint32_t kind, uint32_t dimension) {
  std::string header;
  PutFixed64(&header, kMagic);
  PutFixed32(&header, kVersion);
  PutFixed32(&header, kind);
  PutFixed32(&header, dimension);
  PutFixed32(&header, crc32c::Mask(crc32c::Value(header)));
  return header;
}

void AppendRecord(uint8_t type, std::string_view payload, std::string* out) {
  PutFixed32(out, static_cast<uint32_t>(payload.size()));
  out->push_back(static_cast<char>(type));
  const char type_byte = static_cast<char>(type);
  const uint32_t crc = crc32c::Extend(crc32c::Value(&type_byte, 1), payload.data(), payload.size());
  PutFixed32(out, crc32c::Mask(crc));
  out->append(payload);
}

std::string EncodeFooter(uint64_t records, uint64_t items) {
  std::string payload;
  PutFixed64(&payload, records);
  PutFixed64(&payload, items);
  std::string out;
  AppendRecord(kFooter, payload, &out);
  return out;
}

Reader::~Reader() {
  if (file_ != nullptr) std::fclose(file_);
}

Status Reader::Bad(int64_t offset, const std::string& what) const {
  return Status::Corruption(path_ + ": offset " + std::to_string(offset) + ": " + what);
}

StatusOr<std::unique_ptr<Reader>> Reader::Open(const std::string& path, uint32_t kind,
                                               uint32_t dimension) {
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr)
    return Status::NotFound(path + ": cannot open feature record file: " + std::strerror(errno));
  std::unique_ptr<Reader> reader(new Reader(path, file));
  std::setvbuf(file, nullptr, _IOFBF, size_t{1} << 20);
  char header[kHeaderSize];
  if (std::fread(header, 1, kHeaderSize, file) != kHeaderSize)
    return reader->Bad(0, "truncated header (expected " + std::to_string(kHeaderSize) + " bytes)");
  if (DecodeFixed64(header) != kMagic) return reader->Bad(0, "not a feature record file (magic)");
  if (crc32c::Unmask(DecodeFixed32(header + 20)) != crc32c::Value(header, 20))
    return reader->Bad(0, "header checksum mismatch");
  const uint32_t version = DecodeFixed32(header + 8);
  if (version != kVersion)
    return Status::NotSupported(path + ": feature record version " + std::to_string(version) +
                                ", this build reads " + std::to_string(kVersion));
  if (DecodeFixed32(header + 12) != kind)
    return reader->Bad(12, "kind " + std::to_string(DecodeFixed32(header + 12)) + ", expected " +
                               std::to_string(kind));
  if (DecodeFixed32(header + 16) != dimension)
    return reader->Bad(16, "dimension " + std::to_string(DecodeFixed32(header + 16)) +
                               ", expected " + std::to_string(dimension));
  reader->offset_ = kHeaderSize;
  return reader;
}

StatusOr<bool> Reader::Next(std::string* payload, uint64_t items) {
  if (done_) return false;
  record_offset_ = offset_;
  char head[kRecordHeaderSize];
  const size_t got = std::fread(head, 1, kRecordHeaderSize, file_);
  if (got != kRecordHeaderSize)
    return Bad(offset_, got == 0 ? "truncated: no footer" : "truncated record header");
  const uint32_t length = DecodeFixed32(head);
  const uint8_t type = static_cast<uint8_t>(head[4]);
  if (length > kMaxRecordLength)
    return Bad(offset_, "record length " + std::to_string(length) + " exceeds the maximum " +
                            std::to_string(kMaxRecordLength));
  if (type != kData && type != kFooter) return Bad(offset_, "unknown record type " + std::to_string(type));
  payload->resize(length);
  if (std::fread(payload->data(), 1, length, file_) != length)
    return Bad(offset_, "truncated record (length " + std::to_string(length) + ")");
  const char type_byte = static_cast<char>(type);
  const uint32_t crc = crc32c::Extend(crc32c::Value(&type_byte, 1), payload->data(), length);
  if (crc32c::Unmask(DecodeFixed32(head + 5)) != crc) return Bad(offset_, "record checksum mismatch");
  offset_ += static_cast<int64_t>(kRecordHeaderSize + length);
  if (type == kData) {
    ++records_;
    return true;
  }
  done_ = true;
  if (length != 16) return Bad(record_offset_, "footer length " + std::to_string(length));
  const uint64_t records = DecodeFixed64(payload->data());
  const uint64_t footer_items = DecodeFixed64(payload->data() + 8);
  if (records != records_ || footer_items != items)
    return Bad(record_offset_, "footer counts " + std::to_string(records) + " records, " +
                                   std::to_string(footer_items) + " items; read " +
                                   std::to_string(records_) + " and " + std::to_string(items));
  if (std::fgetc(file_) != EOF) return Bad(offset_, "data after the footer");
  return false;
}

}  // namespace graphslam::storage::feature_records
