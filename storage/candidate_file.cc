#include "storage/candidate_file.h"

#include <cstdio>

#include "storage/chunk_format.h"
#include "storage/feature_record_file.h"

namespace graphslam::storage {

using chunk_format::DecodeDouble;
using chunk_format::DecodeFixed32;
using chunk_format::PutDouble;
using chunk_format::PutFixed32;
using chunk_format::PutFixed64;

CandidateFile::~CandidateFile() {
  if (file_) (void)file_->Close();
  std::remove(path_.c_str());
}

Status CandidateFile::Begin() {
  if (file_) (void)file_->Close();
  file_.reset();
  finished_ = false;
  records_ = 0;
  items_ = 0;
  StatusOr<std::unique_ptr<WritableFile>> file = env_->NewWritableFile(path_);
  GS_RETURN_IF_ERROR(file.status());
  file_ = std::move(file).value();
  buffer_ = feature_records::EncodeHeader(feature_records::kKindCandidates, 2);
  return Status::Ok();
}

Status CandidateFile::Spill(bool force) {
  if (!force && buffer_.size() < (size_t{1} << 20)) return Status::Ok();
  Status status = file_->Append(buffer_);
  buffer_.clear();
  return status.WithContext("writing " + path_);
}

Status CandidateFile::Append(int64_t chunk, const int32_t* features, const core::Point2* values,
                             int64_t count) {
  if (!file_ || finished_)
    return Status::InvalidArgument(path_ + ": Append outside Begin() / Finish()");
  std::string payload;
  payload.reserve(12 + static_cast<size_t>(count) * 20);
  PutFixed64(&payload, static_cast<uint64_t>(chunk));
  PutFixed32(&payload, static_cast<uint32_t>(count));
  for (int64_t k = 0; k < count; ++k) PutFixed32(&payload, static_cast<uint32_t>(features[k]));
  for (int64_t k = 0; k < count; ++k) {
    PutDouble(&payload, values[k].x());
    PutDouble(&payload, values[k].y());
  }
  feature_records::AppendRecord(feature_records::kData, payload, &buffer_);
  ++records_;
  items_ += static_cast<uint64_t>(count);
  return Spill(false);
}

Status CandidateFile::Finish() {
  if (!file_ || finished_)
    return Status::InvalidArgument(path_ + ": Finish() without Begin()");
  buffer_ += feature_records::EncodeFooter(records_, items_);
  GS_RETURN_IF_ERROR(Spill(true));
  GS_RETURN_IF_ERROR(file_->Close().WithContext("closing " + path_));
  file_.reset();
  finished_ = true;
  return Status::Ok();
}

Status CandidateFile::ForEach(const std::function<void(int32_t, const core::Point2&)>& visit) {
  if (!finished_)
    return Status::InvalidArgument(path_ + ": no finished step of candidates to read");
  GS_ASSIGN_OR_RETURN(std::unique_ptr<feature_records::Reader> reader,
                      feature_records::Reader::Open(path_, feature_records::kKindCandidates, 2));
  std::string payload;
  uint64_t items = 0;
  while (true) {
    GS_ASSIGN_OR_RETURN(bool more, reader->Next(&payload, items));
    if (!more) break;
    if (payload.size() < 12)
      return reader->Bad(reader->record_offset(), "candidate record shorter than 12 bytes");
    const uint64_t count = DecodeFixed32(payload.data() + 8);
    if (payload.size() != 12 + count * 20)
      return reader->Bad(reader->record_offset(),
                         "candidate record of " + std::to_string(count) + " features has " +
                             std::to_string(payload.size()) + " bytes, expected " +
                             std::to_string(12 + count * 20));
    const char* ids = payload.data() + 12;
    const char* values = ids + 4 * count;
    for (uint64_t k = 0; k < count; ++k) {
      const int32_t g = static_cast<int32_t>(DecodeFixed32(ids + 4 * k));
      const core::Point2 value(DecodeDouble(values + 16 * k), DecodeDouble(values + 16 * k + 8));
      visit(g, value);
    }
    items += count;
  }
  return Status::Ok();
}

}  // namespace graphslam::storage
