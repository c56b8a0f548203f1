#include "storage/feature_id_file.h"

#include <algorithm>
#include <cstdio>

#include "storage/chunk_format.h"
#include "storage/feature_record_file.h"

namespace graphslam::storage {

using chunk_format::DecodeFixed32;
using chunk_format::DecodeFixed64;
using chunk_format::PutFixed32;
using chunk_format::PutFixed64;

namespace {
constexpr size_t kIdsPerRecord = 65536;
}  // namespace

FeatureIdFile::~FeatureIdFile() {
  if (count_ >= 0) std::remove(path_.c_str());
}

Status FeatureIdFile::Park(std::vector<int64_t>* ids) {
  StatusOr<std::unique_ptr<WritableFile>> opened = env_->NewWritableFile(path_);
  GS_RETURN_IF_ERROR(opened.status());
  std::unique_ptr<WritableFile> file = std::move(opened).value();
  count_ = static_cast<int64_t>(ids->size());
  std::string out = feature_records::EncodeHeader(feature_records::kKindFeatureIds, 2);
  std::string payload;
  uint64_t records = 0;
  for (size_t first = 0; first < ids->size(); first += kIdsPerRecord) {
    const size_t count = std::min(kIdsPerRecord, ids->size() - first);
    payload.clear();
    PutFixed64(&payload, first);
    PutFixed32(&payload, static_cast<uint32_t>(count));
    for (size_t i = first; i < first + count; ++i)
      PutFixed64(&payload, static_cast<uint64_t>((*ids)[i]));
    feature_records::AppendRecord(feature_records::kData, payload, &out);
    ++records;
    if (out.size() >= (size_t{1} << 20)) {
      GS_RETURN_IF_ERROR(file->Append(out).WithContext("writing " + path_));
      out.clear();
    }
  }
  out += feature_records::EncodeFooter(records, ids->size());
  GS_RETURN_IF_ERROR(file->Append(out).WithContext("writing " + path_));
  GS_RETURN_IF_ERROR(file->Close().WithContext("writing " + path_));
  std::vector<int64_t>().swap(*ids);  // the memory goes back (one large block)
  return Status::Ok();
}

Status FeatureIdFile::Restore(std::vector<int64_t>* ids) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<feature_records::Reader> reader,
                      feature_records::Reader::Open(path_, feature_records::kKindFeatureIds, 2));
  ids->clear();
  ids->reserve(static_cast<size_t>(std::max<int64_t>(count_, 0)));
  std::string payload;
  while (true) {
    GS_ASSIGN_OR_RETURN(bool more, reader->Next(&payload, ids->size()));
    if (!more) break;
    const int64_t offset = reader->record_offset();
    if (payload.size() < 12) return reader->Bad(offset, "id record shorter than 12 bytes");
    const uint64_t first = DecodeFixed64(payload.data());
    const uint64_t count = DecodeFixed32(payload.data() + 8);
    if (first != ids->size())
      return reader->Bad(offset, "record starts at feature " + std::to_string(first) +
                                     ", expected " + std::to_string(ids->size()));
    if (payload.size() != 12 + 8 * count)
      return reader->Bad(offset, "record of " + std::to_string(count) + " ids has " +
                                     std::to_string(payload.size()) + " bytes, expected " +
                                     std::to_string(12 + 8 * count));
    for (uint64_t k = 0; k < count; ++k)
      ids->push_back(static_cast<int64_t>(DecodeFixed64(payload.data() + 12 + 8 * k)));
  }
  if (static_cast<int64_t>(ids->size()) != count_)
    return Status::Corruption(path_ + ": " + std::to_string(ids->size()) + " ids, " +
                              std::to_string(count_) + " were parked");
  return Status::Ok();
}

}  // namespace graphslam::storage
