#include "partition/ingest/spill_frames.h"

#include <zstd.h>

#include <cstring>
#include <limits>
#include <memory>

#include "storage/crc32c.h"

namespace graphslam::partition {
namespace {

static_assert(std::numeric_limits<double>::is_iec559);

// Column offsets (in bytes) of a frame of n observations.
struct Columns {
  explicit Columns(size_t n)
      : pose(0), feature(4 * n), kind(8 * n), z(9 * n), information(25 * n), line(57 * n) {}
  size_t pose, feature, kind, z, information, line;
};

template <typename T>
void Put(char* base, size_t offset, size_t i, T value) {
  std::memcpy(base + offset + i * sizeof(T), &value, sizeof(T));
}
template <typename T>
T Get(const char* base, size_t offset, size_t i) {
  T value;
  std::memcpy(&value, base + offset + i * sizeof(T), sizeof(T));
  return value;
}

void PutU32(char* p, uint32_t v) { std::memcpy(p, &v, 4); }
uint32_t GetU32(const char* p) {
  uint32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

// The CRC of a frame: n and payload_bytes (header bytes 4..11), then the payload.
uint32_t FrameCrc(const char* header, const char* payload, size_t payload_bytes) {
  return storage::crc32c::Mask(
      storage::crc32c::Extend(storage::crc32c::Value(header + 4, 8), payload, payload_bytes));
}

std::string At(const std::string& path, int64_t offset) {
  return path + ": spill frame at byte " + std::to_string(offset) + ": ";
}

// The checks of a frame's header before its payload is touched, for frames
// read from a file and frames already in memory alike: `got` header bytes
// were available, then `available` bytes for the payload.
Status CheckHeader(const std::string& path, int64_t offset, const char* header, size_t got) {
  if (got < kSpillFrameHeaderBytes)
    return Status::Corruption(At(path, offset) + "truncated header (" + std::to_string(got) +
                              " of " + std::to_string(kSpillFrameHeaderBytes) + " bytes)");
  if (GetU32(header) != kSpillFrameMagic) return Status::Corruption(At(path, offset) + "bad magic");
  return Status::Ok();
}

Status CheckPayload(const std::string& path, int64_t offset, size_t payload_bytes,
                    size_t available) {
  if (available < payload_bytes)
    return Status::Corruption(At(path, offset) + "truncated: payload of " +
                              std::to_string(payload_bytes) + " bytes, the file has " +
                              std::to_string(available));
  return Status::Ok();
}

}  // namespace

struct SpillFrameEncoder::Context {
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ~Context() { ZSTD_freeCCtx(cctx); }
};

SpillFrameEncoder::SpillFrameEncoder(int zstd_level)
    : level_(zstd_level), context_(std::make_unique<Context>()) {}
SpillFrameEncoder::~SpillFrameEncoder() = default;

Status SpillFrameEncoder::Encode(const core::Observation* observations, size_t n,
                                 std::vector<char>* frame) {
  GS_CHECK(frame != nullptr && n < (size_t{1} << 31));
  const Columns c(n);
  columns_.resize(kSpillRecordBytes * n);
  char* base = columns_.data();
  uint32_t pose = 0, line = 0;
  for (size_t i = 0; i < n; ++i) {
    const core::Observation& o = observations[i];
    Put<uint32_t>(base, c.pose, i, static_cast<uint32_t>(o.pose) - pose);
    pose = static_cast<uint32_t>(o.pose);
    Put<int32_t>(base, c.feature, i, o.feature);
    Put<uint8_t>(base, c.kind, i, static_cast<uint8_t>(o.kind));
    Put<double>(base, c.z, i, o.z(0));
    Put<double>(base, c.z + 8 * n, i, o.z(1));
    for (int e = 0; e < 4; ++e) Put<double>(base, c.information + 8 * n * e, i, o.information(e));
    Put<uint32_t>(base, c.line, i, static_cast<uint32_t>(o.line) - line);
    line = static_cast<uint32_t>(o.line);
  }
  const size_t bound = ZSTD_compressBound(columns_.size());
  compressed_.resize(bound);
  const size_t size = ZSTD_compressCCtx(context_->cctx, compressed_.data(), bound,
                                        columns_.data(), columns_.size(), level_);
  if (ZSTD_isError(size))
    return Status::IOError(std::string("spill frame: zstd compression failed: ") +
                           ZSTD_getErrorName(size));
  if (size > std::numeric_limits<uint32_t>::max())
    return Status::InvalidArgument("spill frame: payload of " + std::to_string(size) + " bytes");
  // The frame's bytes (no compressBound slack). The capacity is kept: the
  // callers reuse a few frame buffers, whose pages are then not fresh (a
  // fault and a zero-fill each) for every frame.
  frame->resize(kSpillFrameHeaderBytes + size);
  std::memcpy(frame->data() + kSpillFrameHeaderBytes, compressed_.data(), size);
  char* header = frame->data();
  PutU32(header, kSpillFrameMagic);
  PutU32(header + 4, static_cast<uint32_t>(n));
  PutU32(header + 8, static_cast<uint32_t>(size));
  PutU32(header + 12, FrameCrc(header, header + kSpillFrameHeaderBytes, size));
  return Status::Ok();
}

struct SpillFrameDecoder::Context {
  ZSTD_DCtx* dctx = ZSTD_createDCtx();
  ~Context() { ZSTD_freeDCtx(dctx); }
};

SpillFrameDecoder::SpillFrameDecoder() : context_(std::make_unique<Context>()) {}
SpillFrameDecoder::~SpillFrameDecoder() = default;

Status SpillFrameDecoder::ReadFile(const std::string& path, storage::ReadableFile* file,
                                   std::vector<core::Observation>* out) {
  int64_t offset = 0;
  while (true) {
    GS_ASSIGN_OR_RETURN(const bool more, ReadFrame(path, file, &offset, out));
    if (!more) return Status::Ok();
  }
}

size_t FrameObservations(const char* frame) { return GetU32(frame + 4); }
size_t FrameBytes(const char* frame) { return kSpillFrameHeaderBytes + GetU32(frame + 8); }

StatusOr<bool> SpillFrameDecoder::ReadRawFrame(const std::string& path,
                                               storage::ReadableFile* file, int64_t offset,
                                               std::vector<char>* frame) {
  GS_CHECK(file != nullptr && frame != nullptr);
  frame->resize(kSpillFrameHeaderBytes);
  GS_ASSIGN_OR_RETURN(const size_t got, file->Read(kSpillFrameHeaderBytes, frame->data()));
  if (got == 0) return false;
  GS_RETURN_IF_ERROR(CheckHeader(path, offset, frame->data(), got));
  const size_t payload_bytes = GetU32(frame->data() + 8);
  frame->resize(kSpillFrameHeaderBytes + payload_bytes);
  GS_ASSIGN_OR_RETURN(const size_t read,
                      file->Read(payload_bytes, frame->data() + kSpillFrameHeaderBytes));
  GS_RETURN_IF_ERROR(CheckPayload(path, offset, payload_bytes, read));
  return true;
}

StatusOr<SpillFrameIndex> IndexSpillFrames(const std::string& path, const char* bytes,
                                           size_t size) {
  SpillFrameIndex index;
  for (size_t offset = 0; offset < size;) {
    const auto at = static_cast<int64_t>(offset);
    GS_RETURN_IF_ERROR(CheckHeader(path, at, bytes + offset, size - offset));
    const size_t payload_bytes = GetU32(bytes + offset + 8);
    GS_RETURN_IF_ERROR(
        CheckPayload(path, at, payload_bytes, size - offset - kSpillFrameHeaderBytes));
    index.offsets.push_back(offset);
    index.firsts.push_back(index.observations);
    index.observations += static_cast<int64_t>(FrameObservations(bytes + offset));
    offset += kSpillFrameHeaderBytes + payload_bytes;
  }
  return index;
}

Status SpillFrameDecoder::DecodeFrame(const std::string& path, int64_t offset, const char* frame,
                                      size_t size, core::Observation* out) {
  GS_CHECK(size >= kSpillFrameHeaderBytes && size == FrameBytes(frame));
  const char* header = frame;
  const char* payload = frame + kSpillFrameHeaderBytes;
  const size_t n = GetU32(header + 4);
  const size_t payload_bytes = GetU32(header + 8);
  if (FrameCrc(header, payload, payload_bytes) != GetU32(header + 12))
    return Status::Corruption(At(path, offset) + "CRC mismatch");
  columns_.resize(kSpillRecordBytes * n);
  const size_t decompressed = ZSTD_decompressDCtx(context_->dctx, columns_.data(), columns_.size(),
                                                  payload, payload_bytes);
  if (ZSTD_isError(decompressed) || decompressed != columns_.size())
    return Status::Corruption(At(path, offset) + "payload does not decompress to " +
                              std::to_string(columns_.size()) + " bytes (" +
                              (ZSTD_isError(decompressed) ? ZSTD_getErrorName(decompressed)
                                                          : std::to_string(decompressed) + " bytes") +
                              ")");
  const Columns c(n);
  const char* base = columns_.data();
  uint32_t pose = 0, line = 0;
  for (size_t i = 0; i < n; ++i) {
    core::Observation& o = out[i];
    pose += Get<uint32_t>(base, c.pose, i);
    o.pose = static_cast<int32_t>(pose);
    o.feature = Get<int32_t>(base, c.feature, i);
    const uint8_t kind = Get<uint8_t>(base, c.kind, i);
    if (!core::IsObservationKind(kind))
      return Status::Corruption(At(path, offset) + "observation " + std::to_string(i) +
                                " has kind " + std::to_string(kind) + "; expected " +
                                core::ObservationKindRange());
    o.kind = static_cast<core::ObservationKind>(kind);
    o.z(0) = Get<double>(base, c.z, i);
    o.z(1) = Get<double>(base, c.z + 8 * n, i);
    for (int e = 0; e < 4; ++e) o.information(e) = Get<double>(base, c.information + 8 * n * e, i);
    line += Get<uint32_t>(base, c.line, i);
    o.line = static_cast<int32_t>(line);
  }
  return Status::Ok();
}

StatusOr<bool> SpillFrameDecoder::ReadFrame(const std::string& path,
                                            storage::ReadableFile* file,
                                            int64_t* offset_in_out,
                                            std::vector<core::Observation>* out) {
  GS_CHECK(file != nullptr && out != nullptr && offset_in_out != nullptr);
  const int64_t offset = *offset_in_out;
  GS_ASSIGN_OR_RETURN(const bool more, ReadRawFrame(path, file, offset, &frame_));
  if (!more) return false;
  const size_t first = out->size();
  out->resize(first + FrameObservations(frame_.data()));
  const Status status = DecodeFrame(path, offset, frame_.data(), frame_.size(), out->data() + first);
  if (!status.ok()) {
    out->resize(first);
    return status;
  }
  *offset_in_out = offset + static_cast<int64_t>(frame_.size());
  return true;
}

StatusOr<int64_t> SpillFrameBoundary(const std::string& path, int64_t observations) {
  StatusOr<std::unique_ptr<storage::ReadableFile>> opened =
      storage::Env::Default()->NewReadableFile(path);
  if (!opened.ok()) {
    if (observations == 0 && opened.status().IsNotFound()) return int64_t{0};
    return Status::IOError(opened.status().message());
  }
  storage::ReadableFile* file = opened.value().get();
  int64_t offset = 0, seen = 0;
  char header[kSpillFrameHeaderBytes];
  while (seen < observations) {
    GS_ASSIGN_OR_RETURN(const size_t got, file->Read(sizeof(header), header));
    if (got != sizeof(header))
      return Status::Corruption(At(path, offset) + "the file ends after " + std::to_string(seen) +
                                " observations; the spill progress records " +
                                std::to_string(observations));
    if (GetU32(header) != kSpillFrameMagic)
      return Status::Corruption(At(path, offset) + "bad magic");
    seen += GetU32(header + 4);
    offset += static_cast<int64_t>(sizeof(header) + GetU32(header + 8));
    GS_RETURN_IF_ERROR(file->Seek(static_cast<uint64_t>(offset)));
  }
  if (seen != observations)
    return Status::Corruption(At(path, offset) + "the recorded " + std::to_string(observations) +
                              " observations end inside a frame (frames end at " +
                              std::to_string(seen) + ")");
  // The last counted frame must lie within the file (a seek past the end succeeds).
  GS_ASSIGN_OR_RETURN(const uint64_t size, file->Size());
  if (static_cast<int64_t>(size) < offset)
    return Status::Corruption(path + ": " + std::to_string(size) + " bytes, shorter than the " +
                              std::to_string(offset) + " bytes of the " +
                              std::to_string(observations) + " recorded observations");
  return offset;
}

}  // namespace graphslam::partition
