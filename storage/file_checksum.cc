#include "storage/file_checksum.h"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <system_error>
#include <vector>

#include "storage/crc32c.h"

namespace graphslam::storage {
namespace {

constexpr size_t kBlockBytes = size_t{1} << 20;

// Extends `*crc` with the bytes of `path`; adds their count to *bytes.
Status ExtendWithFile(const std::string& path, uint32_t* crc, int64_t* bytes) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return Status::NotFound(path + ": no such file");
  std::ifstream in(path, std::ios::binary);
  if (!in) return Status::IOError(path + ": cannot open for reading: " + std::strerror(errno));
  std::vector<char> buffer(kBlockBytes);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    const std::streamsize n = in.gcount();
    if (n <= 0) break;
    *crc = crc32c::Extend(*crc, buffer.data(), static_cast<size_t>(n));
    *bytes += n;
  }
  if (in.bad()) return Status::IOError(path + ": read failed");
  return Status::Ok();
}

}  // namespace

StatusOr<FileChecksum> ChecksumFile(const std::string& path) {
  FileChecksum sum;
  GS_RETURN_IF_ERROR(ExtendWithFile(path, &sum.crc32c, &sum.bytes));
  return sum;
}

StatusOr<FileChecksum> IdentifyInput(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(path, error)) return ChecksumFile(path);
  std::vector<std::string> files;
  for (fs::recursive_directory_iterator it(path, error), end; !error && it != end;
       it.increment(error)) {
    if (it->is_regular_file(error))
      files.push_back(fs::relative(it->path(), path, error).generic_string());
  }
  if (error) return Status::IOError(path + ": list: " + error.message());
  std::sort(files.begin(), files.end());
  FileChecksum sum;
  for (const std::string& file : files) {
    sum.crc32c = crc32c::Extend(sum.crc32c, file.c_str(), file.size() + 1);  // with its '\0'
    GS_RETURN_IF_ERROR(ExtendWithFile((fs::path(path) / file).string(), &sum.crc32c, &sum.bytes));
  }
  return sum;
}

std::string FormatCrc32c(uint32_t crc) {
  char text[16];
  std::snprintf(text, sizeof(text), "%08x", crc);
  return text;
}

bool ParseCrc32c(const std::string& text, uint32_t* crc) {
  if (text.size() != 8 ||
      text.find_first_not_of("0123456789abcdef") != std::string::npos)
    return false;
  *crc = static_cast<uint32_t>(std::stoul(text, nullptr, 16));
  return true;
}

}  // namespace graphslam::storage
