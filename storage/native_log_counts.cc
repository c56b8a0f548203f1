#include "storage/native_log_counts.h"

#include <zstd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <memory>

namespace graphslam::storage {
namespace {

constexpr std::string_view kPrefix = "# counts: ";
// The trailer is one short line: its frame is far below this.
constexpr long kTailBytes = 4096;
constexpr unsigned char kZstdMagic[4] = {0x28, 0xB5, 0x2F, 0xFD};

// The trailer of `text` (the log's last bytes, decompressed): its last line.
bool ParseLastLine(std::string_view text, NativeLogCounts* counts) {
  if (!text.empty() && text.back() == '\n') text.remove_suffix(1);
  const size_t start = text.rfind('\n');
  const std::string line(start == std::string_view::npos ? text : text.substr(start + 1));
  if (line.compare(0, kPrefix.size(), kPrefix) != 0) return false;
  int consumed = 0;
  if (std::sscanf(line.c_str(),
                  "# counts: poses %" SCNd64 " features %" SCNd64 " observations %" SCNd64 "%n",
                  &counts->poses, &counts->features, &counts->observations, &consumed) != 3)
    return false;
  // The optional id range.
  counts->feature_id_end = -1;
  if (static_cast<size_t>(consumed) < line.size()) {
    int more = 0;
    if (std::sscanf(line.c_str() + consumed, " feature_ids %" SCNd64 "%n", &counts->feature_id_end,
                    &more) != 1 || counts->feature_id_end < 0)
      return false;
    consumed += more;
  }
  return static_cast<size_t>(consumed) == line.size() && counts->poses >= 0 &&
         counts->features >= 0 && counts->observations >= 0;
}

// The last frame of a zstd tail that ends exactly at the end, decompressed.
bool LastZstdFrame(const std::string& tail, std::string* text) {
  if (tail.size() < 4) return false;
  for (size_t at = tail.size() - 3; at-- > 0;) {
    if (std::memcmp(tail.data() + at, kZstdMagic, 4) == 0) {
      const size_t size = tail.size() - at;
      if (ZSTD_findFrameCompressedSize(tail.data() + at, size) == size) {
        std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> context(ZSTD_createDCtx(),
                                                                   ZSTD_freeDCtx);
        text->assign(kTailBytes, '\0');
        ZSTD_inBuffer in{tail.data() + at, size, 0};
        ZSTD_outBuffer out{text->data(), text->size(), 0};
        const size_t result = ZSTD_decompressStream(context.get(), &out, &in);
        if (ZSTD_isError(result) || result != 0) return false;
        text->resize(out.pos);
        return true;
      }
    }
  }
  return false;
}

}  // namespace

std::string NativeLogCountsLine(const NativeLogCounts& counts) {
  return std::string(kPrefix) + "poses " + std::to_string(counts.poses) + " features " +
         std::to_string(counts.features) + " observations " +
         std::to_string(counts.observations) +
         (counts.feature_id_end >= 0 ? " feature_ids " + std::to_string(counts.feature_id_end)
                                     : std::string()) +
         "\n";
}

StatusOr<NativeLogCounts> ReadNativeLogCounts(const std::string& path) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"),
                                                       std::fclose);
  if (file == nullptr)
    return Status::IOError(path + ": cannot open: " + std::strerror(errno));
  unsigned char head[4] = {0, 0, 0, 0};
  const bool zstd = std::fread(head, 1, 4, file.get()) == 4 && std::memcmp(head, kZstdMagic, 4) == 0;
  if (std::fseek(file.get(), 0, SEEK_END) != 0)
    return Status::IOError(path + ": seek: " + std::strerror(errno));
  const long size = std::ftell(file.get());
  const long tail_bytes = size < kTailBytes ? size : kTailBytes;
  std::string tail(static_cast<size_t>(tail_bytes), '\0');
  if (std::fseek(file.get(), size - tail_bytes, SEEK_SET) != 0 ||
      std::fread(tail.data(), 1, tail.size(), file.get()) != tail.size())
    return Status::IOError(path + ": cannot read its last " + std::to_string(tail_bytes) +
                           " bytes");
  std::string text;
  if (zstd && !LastZstdFrame(tail, &text))
    return Status::NotFound(path + ": no counts trailer (its last zstd frame is not one)");
  NativeLogCounts counts;
  if (!ParseLastLine(zstd ? text : tail, &counts))
    return Status::NotFound(path + ": no counts trailer (last line is not '# counts: ...')");
  return counts;
}

}  // namespace graphslam::storage
