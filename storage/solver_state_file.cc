#include "storage/solver_state_file.h"

#include <algorithm>
#include <cstring>

#include "storage/atomic_file.h"
#include "storage/chunk_format.h"
#include "storage/feature_record_file.h"

namespace graphslam::storage {
namespace {

using chunk_format::DecodeDouble;
using chunk_format::DecodeFixed32;
using chunk_format::DecodeFixed64;
using chunk_format::PutDouble;
using chunk_format::PutFixed32;
using chunk_format::PutFixed64;

constexpr uint32_t kDimension = 2;
constexpr size_t kElementsPerRecord = 65536;
constexpr uint8_t kSummary = 0;
constexpr uint8_t kPoses = 1;
constexpr uint8_t kPreviousX = 2;
constexpr uint8_t kForestOrder = 3;
constexpr uint8_t kForestParent = 4;
constexpr size_t kSummarySize = 1 + 8 + 1 + 3 * 8 + 1 + 8 + 8;
constexpr size_t kRecordPrefix = 1 + 8 + 4;  // section, first, count

const char* SectionName(uint8_t section) {
  switch (section) {
    case kPoses: return "poses";
    case kPreviousX: return "previous_x";
    case kForestOrder: return "forest_order";
    case kForestParent: return "forest_parent";
    default: return "summary";
  }
}

// Bytes per element of a section.
size_t ElementSize(uint8_t section) {
  return section == kPoses ? 24 : section == kPreviousX ? 8 : 4;
}

}  // namespace

Status WriteSolverStateFile(Env* env, const std::string& path,
                            const std::vector<core::Pose2>& poses,
                            const core::PcgSolverState& pcg) {
  if (pcg.forest_order.size() != pcg.forest_parent.size())
    return Status::InvalidArgument(path + ": forest_order has " +
                                   std::to_string(pcg.forest_order.size()) +
                                   " entries, forest_parent " +
                                   std::to_string(pcg.forest_parent.size()));
  return WriteFileAtomically(env, path, [&](WritableFile* file) -> Status {
    std::string out = feature_records::EncodeHeader(feature_records::kKindSolverState, kDimension);
    std::string payload;
    uint64_t records = 0;
    payload.push_back(static_cast<char>(kSummary));
    PutFixed64(&payload, poses.size());
    payload.push_back(static_cast<char>(pcg.present));
    PutDouble(&payload, pcg.eta);
    PutDouble(&payload, pcg.previous_rhs_norm);
    PutDouble(&payload, pcg.last_rhs_norm);
    payload.push_back(static_cast<char>(pcg.have_previous));
    PutFixed64(&payload, pcg.previous_x.size());
    PutFixed64(&payload, pcg.forest_order.size());
    feature_records::AppendRecord(feature_records::kData, payload, &out);
    ++records;
    // One section's elements in records of kElementsPerRecord.
    const auto section = [&](uint8_t id, size_t n, const auto& put) -> Status {
      for (size_t first = 0; first < n; first += kElementsPerRecord) {
        const size_t count = std::min(kElementsPerRecord, n - first);
        payload.clear();
        payload.push_back(static_cast<char>(id));
        PutFixed64(&payload, first);
        PutFixed32(&payload, static_cast<uint32_t>(count));
        for (size_t i = first; i < first + count; ++i) put(i);
        feature_records::AppendRecord(feature_records::kData, payload, &out);
        ++records;
        if (out.size() >= (size_t{1} << 20)) {
          GS_RETURN_IF_ERROR(file->Append(out));
          out.clear();
        }
      }
      return Status::Ok();
    };
    GS_RETURN_IF_ERROR(section(kPoses, poses.size(), [&](size_t i) {
      for (int k = 0; k < 3; ++k) PutDouble(&payload, poses[i][k]);
    }));
    GS_RETURN_IF_ERROR(section(kPreviousX, pcg.previous_x.size(),
                               [&](size_t i) { PutDouble(&payload, pcg.previous_x[i]); }));
    GS_RETURN_IF_ERROR(section(kForestOrder, pcg.forest_order.size(), [&](size_t i) {
      PutFixed32(&payload, static_cast<uint32_t>(pcg.forest_order[i]));
    }));
    GS_RETURN_IF_ERROR(section(kForestParent, pcg.forest_parent.size(), [&](size_t i) {
      PutFixed32(&payload, static_cast<uint32_t>(pcg.forest_parent[i]));
    }));
    out += feature_records::EncodeFooter(
        records, poses.size() + pcg.previous_x.size() + 2 * pcg.forest_order.size());
    return file->Append(out);
  });
}

namespace {

// What ReadSolverStateFile fills, section by section, and the sizes of the
// sections as the summary record names them.
class StateSections {
 public:
  StateSections(std::vector<core::Pose2>* poses, core::PcgSolverState* pcg)
      : poses_(poses), pcg_(pcg) {}

  // Section 0 (after its tag byte): the PCG scalars and the sizes of the
  // sections that follow. Reserves only what a record could plausibly hold:
  // the counts come from a CRC-checked record, but a wrong writer could
  // still name absurd sizes.
  void ReadSummary(const char* p) {
    expected_[kPoses] = DecodeFixed64(p);
    *pcg_ = core::PcgSolverState();
    pcg_->present = p[8] != 0;
    pcg_->eta = DecodeDouble(p + 9);
    pcg_->previous_rhs_norm = DecodeDouble(p + 17);
    pcg_->last_rhs_norm = DecodeDouble(p + 25);
    pcg_->have_previous = p[33] != 0;
    expected_[kPreviousX] = DecodeFixed64(p + 34);
    expected_[kForestOrder] = expected_[kForestParent] = DecodeFixed64(p + 42);
    constexpr uint64_t kMaxReserve = uint64_t{1} << 28;
    poses_->clear();
    poses_->reserve(std::min(expected_[kPoses], kMaxReserve));
    pcg_->previous_x.reserve(std::min(expected_[kPreviousX], kMaxReserve));
    pcg_->forest_order.reserve(std::min(expected_[kForestOrder], kMaxReserve));
    pcg_->forest_parent.reserve(std::min(expected_[kForestParent], kMaxReserve));
  }

  uint64_t expected(uint8_t section) const { return expected_[section]; }
  uint64_t SizeOf(uint8_t section) const {
    switch (section) {
      case kPoses: return poses_->size();
      case kPreviousX: return pcg_->previous_x.size();
      case kForestOrder: return pcg_->forest_order.size();
      default: return pcg_->forest_parent.size();
    }
  }

  void Append(uint8_t section, const char* values, uint64_t count) {
    for (uint64_t i = 0; i < count; ++i) {
      switch (section) {
        case kPoses:
          poses_->emplace_back(DecodeDouble(values + 24 * i), DecodeDouble(values + 24 * i + 8),
                               DecodeDouble(values + 24 * i + 16));
          break;
        case kPreviousX: pcg_->previous_x.push_back(DecodeDouble(values + 8 * i)); break;
        case kForestOrder:
          pcg_->forest_order.push_back(static_cast<int32_t>(DecodeFixed32(values + 4 * i)));
          break;
        default:
          pcg_->forest_parent.push_back(static_cast<int32_t>(DecodeFixed32(values + 4 * i)));
      }
    }
  }

 private:
  std::vector<core::Pose2>* const poses_;
  core::PcgSolverState* const pcg_;
  uint64_t expected_[5] = {0, 0, 0, 0, 0};  // by section
};

// A data record must continue the section being read (*current, which moves
// past the sections that are complete), from its next element, within the
// size the summary names.
Status CheckDataRecord(const feature_records::Reader& reader, const std::string& payload,
                       const StateSections& sections, uint8_t* current) {
  const int64_t offset = reader.record_offset();
  if (payload.size() < kRecordPrefix)
    return reader.Bad(offset, "record shorter than " + std::to_string(kRecordPrefix) + " bytes");
  const uint8_t section = static_cast<uint8_t>(payload[0]);
  const uint64_t first = DecodeFixed64(payload.data() + 1);
  const uint64_t count = DecodeFixed32(payload.data() + 9);
  // Skip the sections that are complete (or empty) up to this record's.
  while (*current <= kForestParent &&
         sections.SizeOf(*current) == sections.expected(*current) && section != *current)
    ++*current;
  if (section != *current || section < kPoses || section > kForestParent)
    return reader.Bad(offset, "record of section " + std::to_string(section) + ", expected " +
                                  std::to_string(*current) + " (" + SectionName(*current) + ")");
  if (first != sections.SizeOf(section) || first + count > sections.expected(section))
    return reader.Bad(offset, std::string(SectionName(section)) + " record of " +
                                  std::to_string(count) + " elements from " +
                                  std::to_string(first) + ", expected from " +
                                  std::to_string(sections.SizeOf(section)) + " of " +
                                  std::to_string(sections.expected(section)));
  if (payload.size() != kRecordPrefix + ElementSize(section) * count)
    return reader.Bad(offset, std::string(SectionName(section)) + " record of " +
                                  std::to_string(count) + " elements has " +
                                  std::to_string(payload.size()) + " bytes, expected " +
                                  std::to_string(kRecordPrefix + ElementSize(section) * count));
  return Status::Ok();
}

}  // namespace

Status ReadSolverStateFile(const std::string& path, std::vector<core::Pose2>* poses,
                           core::PcgSolverState* pcg) {
  GS_ASSIGN_OR_RETURN(std::unique_ptr<feature_records::Reader> reader,
                      feature_records::Reader::Open(path, feature_records::kKindSolverState,
                                                    kDimension));
  std::string payload;
  GS_ASSIGN_OR_RETURN(bool more, reader->Next(&payload, 0));
  if (!more) return reader->Bad(feature_records::kHeaderSize, "no summary record");
  if (payload.size() != kSummarySize || payload[0] != static_cast<char>(kSummary))
    return reader->Bad(reader->record_offset(),
                       "summary record of " + std::to_string(payload.size()) +
                           " bytes, expected section 0 of " + std::to_string(kSummarySize));
  StateSections sections(poses, pcg);
  sections.ReadSummary(payload.data() + 1);
  uint8_t current = kPoses;
  uint64_t items = 0;
  while (true) {
    GS_ASSIGN_OR_RETURN(more, reader->Next(&payload, items));
    if (!more) break;
    GS_RETURN_IF_ERROR(CheckDataRecord(*reader, payload, sections, &current));
    const uint8_t section = static_cast<uint8_t>(payload[0]);
    const uint64_t count = DecodeFixed32(payload.data() + 9);
    sections.Append(section, payload.data() + kRecordPrefix, count);
    items += count;
  }
  for (uint8_t section = kPoses; section <= kForestParent; ++section) {
    if (sections.SizeOf(section) != sections.expected(section))
      return Status::Corruption(path + ": " + std::to_string(sections.SizeOf(section)) + " " +
                                SectionName(section) + " elements, the summary names " +
                                std::to_string(sections.expected(section)));
  }
  return Status::Ok();
}

}  // namespace graphslam::storage
