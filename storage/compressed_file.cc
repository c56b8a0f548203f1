#include "storage/compressed_file.h"

#include <zstd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <vector>

namespace graphslam::storage {
namespace {

constexpr unsigned char kZstdMagic[4] = {0x28, 0xB5, 0x2F, 0xFD};  // 0xFD2FB528, little endian
// The decompressed-size sanity bound (compressed_file.h).
constexpr int64_t kMaxExpansion = 1024;
constexpr int64_t kExpansionSlack = int64_t{64} << 20;

struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};
using FilePointer = std::unique_ptr<std::FILE, FileCloser>;

class PlainInputFile : public InputFile {
 public:
  PlainInputFile(std::string path, FilePointer file, int64_t offset)
      : path_(std::move(path)), file_(std::move(file)), offset_(offset) {}
  size_t Read(char* data, size_t size, Status* status) override {
    const size_t got = std::fread(data, 1, size, file_.get());
    offset_ += static_cast<int64_t>(got);
    if (got < size && std::ferror(file_.get()))
      *status = Status::IOError(path_ + ": read error after byte " + std::to_string(offset_));
    return got;
  }
  bool compressed() const override { return false; }

 private:
  std::string path_;
  FilePointer file_;
  int64_t offset_;
};

// Streaming decompression: the compressed file is read in ZSTD_DStreamInSize
// pieces; `pending_` is zstd's hint of what the current frame still needs
// (0 between frames), which tells a clean end from a truncated one.
class ZstdInputFile : public InputFile {
 public:
  ZstdInputFile(std::string path, FilePointer file)
      : path_(std::move(path)), file_(std::move(file)), context_(ZSTD_createDCtx()) {
    input_.resize(ZSTD_DStreamInSize());
  }
  ~ZstdInputFile() override { ZSTD_freeDCtx(context_); }

  size_t Read(char* data, size_t size, Status* status) override {
    ZSTD_outBuffer out = {data, size, 0};
    while (out.pos < out.size) {
      // A sanity bound on the expansion (a "zstd bomb": 30 KB that inflate to
      // 1 GB): text logs compress 3-20x; kMaxExpansion times what was read,
      // plus kExpansionSlack, is far beyond that. Checked before producing
      // more, so that a read that stops here gives fewer bytes than asked
      // (the interface's sign of an error).
      const int64_t produced = decompressed_ + static_cast<int64_t>(out.pos);
      if (produced > kMaxExpansion * compressed_offset_ + kExpansionSlack) {
        *status = Status::Corruption(
            path_ + ": " + std::to_string(produced) + " decompressed bytes from " +
            std::to_string(compressed_offset_) + " compressed bytes; expected at most " +
            std::to_string(kMaxExpansion) + " times the compressed size plus " +
            std::to_string(kExpansionSlack >> 20) +
            " MiB (text compresses 3-20x; this looks like a decompression bomb)");
        break;
      }
      if (in_.pos == in_.size) {
        if (end_of_file_) {
          if (pending_ != 0)
            *status = Status::Corruption(
                path_ + ": truncated zstd stream: the file ends inside a frame at compressed "
                        "offset " + std::to_string(compressed_offset_) + " (decompressed offset " +
                std::to_string(decompressed_ + static_cast<int64_t>(out.pos)) +
                "); expected the rest of the frame");
          break;
        }
        const size_t got = std::fread(input_.data(), 1, input_.size(), file_.get());
        if (got < input_.size()) {
          if (std::ferror(file_.get())) {
            *status = Status::IOError(path_ + ": read error after compressed byte " +
                                      std::to_string(compressed_offset_ + static_cast<int64_t>(got)));
            break;
          }
          end_of_file_ = true;
        }
        in_ = {input_.data(), got, 0};
        block_start_ = compressed_offset_;
        compressed_offset_ += static_cast<int64_t>(got);
        if (got == 0) continue;
      }
      const size_t result = ZSTD_decompressStream(context_, &out, &in_);
      if (ZSTD_isError(result)) {
        *status = Status::Corruption(
            path_ + ": corrupt zstd data (" + ZSTD_getErrorName(result) +
            ") in the compressed bytes before offset " +
            std::to_string(block_start_ + static_cast<int64_t>(in_.pos)) + " (decompressed offset " +
            std::to_string(decompressed_ + static_cast<int64_t>(out.pos)) +
            "); expected a valid zstd stream");
        break;
      }
      pending_ = result;
    }
    decompressed_ += static_cast<int64_t>(out.pos);
    return out.pos;
  }
  bool compressed() const override { return true; }

 private:
  std::string path_;
  FilePointer file_;
  ZSTD_DCtx* context_;
  std::vector<char> input_;
  ZSTD_inBuffer in_ = {nullptr, 0, 0};
  int64_t compressed_offset_ = 0;  // bytes of the file read so far
  int64_t block_start_ = 0;        // file offset of input_[0]
  int64_t decompressed_ = 0;
  size_t pending_ = 0;
  bool end_of_file_ = false;
};

}  // namespace

bool IsZstdFile(const std::string& path) {
  FilePointer file(std::fopen(path.c_str(), "rb"));
  if (!file) return false;
  unsigned char head[4];
  return std::fread(head, 1, 4, file.get()) == 4 && std::memcmp(head, kZstdMagic, 4) == 0;
}

StatusOr<std::unique_ptr<InputFile>> InputFile::Open(const std::string& path, int64_t offset) {
  GS_CHECK(offset >= 0);
  std::error_code error;
  if (!std::filesystem::exists(path, error))
    return Status::NotFound(path + ": no such file; expected an existing input file");
  if (std::filesystem::is_directory(path, error))
    return Status::InvalidArgument(path + ": is a directory; expected a file");
  FilePointer file(std::fopen(path.c_str(), "rb"));
  if (!file) return Status::IOError(path + ": cannot open for reading");
  if (!IsZstdFile(path)) {
    if (offset > 0 && fseeko(file.get(), static_cast<off_t>(offset), SEEK_SET) != 0)
      return Status::IOError(path + ": seek to byte " + std::to_string(offset) + ": " +
                             std::strerror(errno));
    return std::unique_ptr<InputFile>(new PlainInputFile(path, std::move(file), offset));
  }
  auto input = std::make_unique<ZstdInputFile>(path, std::move(file));
  // No index into the frames: decompress and drop up to `offset`.
  std::vector<char> scratch(size_t{1} << 20);
  int64_t skipped = 0;
  while (skipped < offset) {
    Status status;
    const auto want = static_cast<size_t>(
        std::min<int64_t>(offset - skipped, static_cast<int64_t>(scratch.size())));
    const size_t got = input->Read(scratch.data(), want, &status);
    GS_RETURN_IF_ERROR(status);
    if (got < want)
      return Status::Corruption(path + ": the decompressed data end at byte " +
                                std::to_string(skipped + static_cast<int64_t>(got)) +
                                "; expected at least " + std::to_string(offset) +
                                " bytes (a resume point)");
    skipped += static_cast<int64_t>(got);
  }
  return std::unique_ptr<InputFile>(std::move(input));
}

struct ZstdWriter::Context {
  ZSTD_CCtx* context = ZSTD_createCCtx();
  ~Context() { ZSTD_freeCCtx(context); }
};

ZstdWriter::ZstdWriter(WritableFile* file, int level, int workers)
    : file_(file), context_(std::make_unique<Context>()) {
  GS_CHECK(file_ != nullptr && context_->context != nullptr);
  ZSTD_CCtx_setParameter(context_->context, ZSTD_c_compressionLevel, level);
  ZSTD_CCtx_setParameter(context_->context, ZSTD_c_checksumFlag, 1);
  // A libzstd without threads refuses workers; it then compresses inline.
  if (workers > 0) ZSTD_CCtx_setParameter(context_->context, ZSTD_c_nbWorkers, workers);
  out_.resize(ZSTD_CStreamOutSize());
}

ZstdWriter::~ZstdWriter() = default;

Status ZstdWriter::Compress(std::string_view data, bool end) {
  ZSTD_inBuffer in = {data.data(), data.size(), 0};
  const ZSTD_EndDirective mode = end ? ZSTD_e_end : ZSTD_e_continue;
  while (true) {
    ZSTD_outBuffer out = {out_.data(), out_.size(), 0};
    const size_t remaining = ZSTD_compressStream2(context_->context, &out, &in, mode);
    if (ZSTD_isError(remaining))
      return Status::IOError(std::string("zstd compression failed: ") +
                             ZSTD_getErrorName(remaining));
    if (out.pos > 0) {
      GS_RETURN_IF_ERROR(file_->Append(std::string_view(out_.data(), out.pos)));
      bytes_out_ += static_cast<int64_t>(out.pos);
    }
    if (end ? remaining == 0 : in.pos == in.size) break;
  }
  return Status::Ok();
}

Status ZstdWriter::Append(std::string_view data) {
  GS_CHECK(!finished_);
  bytes_in_ += static_cast<int64_t>(data.size());
  return Compress(data, false);
}

Status ZstdWriter::Finish() {
  GS_CHECK(!finished_);
  finished_ = true;
  return Compress(std::string_view(), true);
}

}  // namespace graphslam::storage
